#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/run/run.h"

namespace nvs::cli {

static_assert(rt::kRunFailed == kExitFailure && rt::kRunOutputFailed == kExitOutputFailed &&
              rt::kRunInterrupted == kExitInterrupted);

int runRun(const RunOptions& opts) {
    rt::RunRequest req;
    req.scenario = opts.scenario;
    req.outputs = opts.outputs;
    req.clock = opts.clock == "sim" ? rt::ClockKind::Sim : rt::ClockKind::Wall;
    req.frames = opts.frames;
    req.telemetry = opts.telemetry;
    req.statsPath = opts.statsPath;
    req.dirs = resolveDataDirs();
    // 0, 1, or the bits 4 (an output failed) and 8 (interrupted): docs/contracts.md.
    return rt::runScenario(req, stderr);
}

}  // namespace nvs::cli
