#pragma once
// The sweep's table (docs/sweep.md, "Results"; docs/contracts.md, "sweep"): one row a job of
// the manifest, in its order, from the jobs' result.json files:
//   index, the grid's axes (sweep.json "axes"), status (ok | failed | timeout | missing),
//   exit_status, the metrics (run: metrics.h; command: none), wall_s, host, error
// written as DIR/results.csv (RFC 4180) and DIR/results.json; a command's joined file
// (spec key concat); and plots of each metric against each axis that varies
// (DIR/plots/METRIC-vs-AXIS.png, drawn by sweep_plots.py with Matplotlib).

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

namespace nvs::rt::sweep {

struct GatherCounts {
    std::int64_t ok = 0, failed = 0, missing = 0;
};

// Rebuilds the table and plots of the sweep folder `dir`. `plotScript` empty: no plots. Notes
// (a plot that could not be drawn) go to `log`. Throws SetupError where dir is not a sweep.
GatherCounts gatherSweep(const std::filesystem::path& dir, const std::filesystem::path& plotScript,
                         std::FILE* log);

// The columns of the table of a sweep with these axes (kind run or command).
std::vector<std::string> resultColumns(const std::vector<std::string>& axes, bool run);

// The plots' script: <config>/tools/sweep_plots.py where it is installed there, else the one
// in the source tree nvstim was built from; "" where neither exists.
std::filesystem::path plotScriptFor(const std::filesystem::path& configDir);

// A CSV field, quoted where RFC 4180 needs it.
std::string csvField(const std::string& text);

}  // namespace nvs::rt::sweep
