#pragma once
// Where this `nvstim` process finds its shipped data and keeps its caches: resolved once by the
// command line and handed down to everything it creates (sim/ reads no environment).
//
//   config  $NVS_CONFIG_DIR if set; else <directory of the executable>/../share/nvstim/config
//           if it exists (an installed nvstim); else the source tree's config/ this binary was
//           built from
//   cache   $NVS_CACHE_DIR if set; else $XDG_CACHE_HOME/nvstim; else $HOME/.cache/nvstim; else
//           <temporary directory>/nvstim-cache

#include <filesystem>
#include <functional>

#include "sim/core/paths.h"

namespace nvs::cli {

// The rules above for this process (reads the environment and /proc/self/exe).
DataDirs resolveDataDirs();

// The same rules with the environment given as a lookup (nullptr: unset) and the executable's
// directory given (for tests).
DataDirs resolveDataDirs(const std::function<const char*(const char*)>& env,
                         const std::filesystem::path& exeDir);

}  // namespace nvs::cli
