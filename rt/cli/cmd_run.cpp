#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/run/run.h"

namespace nvs::cli {

int runRun(const RunOptions& opts) {
    rt::RunRequest req;
    req.scenario = opts.scenario;
    req.outputs = opts.outputs;
    req.clock = opts.clock == "sim" ? rt::ClockKind::Sim : rt::ClockKind::Wall;
    req.frames = opts.frames;
    req.telemetry = opts.telemetry;
    req.statsPath = opts.statsPath;
    req.dirs = resolveDataDirs();
    return rt::runScenario(req, stderr) == 0 ? kExitOk : kExitFailure;
}

}  // namespace nvs::cli
