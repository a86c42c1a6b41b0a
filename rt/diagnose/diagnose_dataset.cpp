#include "rt/diagnose/diagnose_dataset.h"

#include "rt/compose/scene_stimulus.h"
#include "sim/core/error.h"
#include "sim/core/input_file.h"
#include "sim/fit/diagnose.h"

namespace nvs::rt {

fit::Dataset loadDiagnoseDataset(const std::filesystem::path& dir, const DataDirs& dirs,
                                 const fit::Progress& progress) {
    // A scenario stimulus is rendered while reading (no progress while reading radiance files:
    // a bad dataset is one line).
    auto renderScenario =
        [&](const std::filesystem::path& scenario, const sensor::CameraParams& cam,
            const std::filesystem::path& presetFile, const sensor::Overrides& settings) {
            return makeSceneStimulus(scenario, cam, presetFile, settings, dirs);
        };
    return fit::loadDataset(dir, dirs.config, progress, renderScenario);
}

std::string diagnoseDatasetJson(const std::filesystem::path& dir, const DataDirs& dirs,
                                std::uint64_t seed, const fit::Progress& progress) {
    if (!isDirectory(dir))
        throw SetupError(dir.string() + ": not a dataset folder (no such folder)");
    const fit::Dataset d = loadDiagnoseDataset(dir, dirs, progress);
    fit::Options o;
    o.seed = seed;
    return fit::toJson(fit::diagnose(d, dirs.config, o, progress));
}

}  // namespace nvs::rt
