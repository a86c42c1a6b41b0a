#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/run/run.h"
#include "sim/core/error.h"
#include "sim/render/renderer.h"
#include "sim/sensor/camera.h"

namespace nvs::cli {

static_assert(rt::kRunFailed == kExitFailure && rt::kRunOutputFailed == kExitOutputFailed &&
              rt::kRunInterrupted == kExitInterrupted);

int runRun(const RunOptions& opts) {
    // A run that would write nothing is a mistake of the command line: --stats alone is a run
    // measured (its statistics the output), anything else names an output.
    if (opts.outputs.empty() && !opts.statsPath) {
        throw SetupError(
            "run: no --output: give at least one, e.g. --output y4m:FILE.y4m, png:DIR, pgm:DIR, "
            "exr:DIR, meta:FILE.jsonl, contact:FILE.png or v4l2:/dev/videoN (see run --help)");
    }
    rt::RunRequest req;
    req.dirs = resolveDataDirs();
    req.scenario = resolveScenario(opts.scenario, scenariosDir(req.dirs));
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
    req.overrides.cameraPreset = opts.camera;
    req.overrides.cameraSets = sensor::parseOverrides(opts.sets);
    // 0, 1, or the bits 4 (an output failed) and 8 (interrupted): docs/contracts.md.
    return rt::runScenario(req, stderr);
}

}  // namespace nvs::cli
