#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/run/run.h"
#include "sim/core/error.h"
#include "sim/render/renderer.h"

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
    if (opts.primaryVisibility) {
        render::PrimaryVisibility v;
        if (!render::parsePrimaryVisibility(*opts.primaryVisibility, &v)) {
            throw SetupError("--primary-visibility: must be embree, gl or auto");
        }
        req.primaryVisibility = v;
    }
    req.renderThreads = opts.renderThreads;
    req.cameraThreads = opts.cameraThreads;
    req.dirs = resolveDataDirs();
    // 0, 1, or the bits 4 (an output failed) and 8 (interrupted): docs/contracts.md.
    return rt::runScenario(req, stderr);
}

}  // namespace nvs::cli
