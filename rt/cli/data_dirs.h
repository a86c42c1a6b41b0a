#pragma once
// Where this `nvstim` process finds its shipped data and keeps its caches: resolved once by the
// command line and handed down to everything it creates (sim/ reads no environment).
//
//   config  $NVS_CONFIG_DIR if set; else <directory of the executable>/../share/nvstim/config
//           if it exists (an installed nvstim); else the source tree's config/ this binary was
//           built from
//   cache   $NVS_CACHE_DIR if set; else $XDG_CACHE_HOME/nvstim; else $HOME/.cache/nvstim; else
//           <temporary directory>/nvstim-cache
//   scenarios  the folder `scenarios` beside the config folder (an installed tree's
//           PREFIX/share/nvstim/scenarios, the source tree's scenarios/): where a bare scenario
//           name (`nvstim run thesis-stlamp`) is looked up

#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "sim/core/paths.h"

namespace nvs::cli {

// The rules above for this process (reads the environment and /proc/self/exe).
DataDirs resolveDataDirs();

// The same rules with the environment given as a lookup (nullptr: unset) and the executable's
// directory given (for tests).
DataDirs resolveDataDirs(const std::function<const char*(const char*)>& env,
                         const std::filesystem::path& exeDir);

// The shipped scenarios' folder of these data folders: `scenarios` beside `config`.
std::filesystem::path scenariosDir(const DataDirs& dirs);

// The scenarios in `dir`: the names of its folders that hold a scenario.toml, sorted.
std::vector<std::string> scenarioNames(const std::filesystem::path& dir);

// A SCENARIO argument of run, render and replay: a file or folder that exists as given; else a
// bare name (no '/') of a scenario in `dir` (DIR/NAME/ holding scenario.toml, or DIR/NAME.toml).
// Anything else is a SetupError naming the argument, the folder searched and the nearest names.
std::string resolveScenario(const std::string& arg, const std::filesystem::path& dir);

}  // namespace nvs::cli
