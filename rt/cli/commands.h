#pragma once
// One handler per subcommand, each in its own cmd_<name>.cpp. A handler returns the process
// exit status (cli.h ExitCode) and may throw SetupError for bad input (printed as one line).

#include "rt/cli/cli.h"

namespace nvs::cli {

int runRun(const RunOptions& opts);
int runEphem(const EphemOptions& opts);
int runIllum(const IllumOptions& opts);
int runRender(const RenderOptions& opts);
int runSensor(const SensorOptions& opts);
int runReplay(const ReplayOptions& opts);
int runDiagnose(const DiagnoseOptions& opts);
int runBench(const BenchOptions& opts);
int runList(const ListOptions& opts);
int runSweep(const SweepOptions& opts);

}  // namespace nvs::cli
