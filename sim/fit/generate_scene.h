#pragma once
// Hidden scenario effects (docs/design.md §9): datasets whose stimulus is rendered from a scenario.
// The truth renders the scene with a random strength of one scenario effect (lunar sky light
// scale, site pressure for refraction, cloud optical depth), the model under test is the same
// scenario without it. The scene is the thesis's RIT roof (sceneSetupFor): for the null and
// lunar sky datasets through the scene's own camera under a setting Moon, frames every few
// minutes for about three hours, from 23° down to the horizon (1998-09-02, the thesis's Table
// 4-2 night); for refraction the camera on the roof turned to the setting Moon's disk; for the
// cloud a whole night under the full Moon (both halves of the dataset see the air mass change);
// for the visibility (the truth's, the model keeping the scenario's 23 km) the rising Moon, from
// 2.6° up.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "sim/fit/generate.h"

namespace nvs::fit {

struct SceneGenSpec {
    std::string effect;  // "": a null dataset
    std::uint64_t seed = 1;
    int width = 128, height = 96;
    int frames = 48;
    std::filesystem::path sceneFile;  // scene TOML (the RIT roof)
    std::filesystem::path workDir;    // where the model's scenario file is written
};

// The detectable range of each scenario effect's strength (docs/validation.md).
const std::vector<EffectRange>& sceneEffectRanges();

// How a dataset of the RIT roof is taken: when, how often, which lamps burn, and where the
// camera looks (the scene's own camera, or a [platform] pose at the site).
struct SceneSetup {
    std::string utcStart = "1998-09-02T03:00:00Z";
    double framePeriod_s = 232.0;
    double gain_V = 6.0;
    std::vector<std::string> lampsOn;
    bool posed = false;  // a [platform] pose: at the site, this high, turned so
    double cameraHeight_m = 0.0, yaw_deg = 0.0, pitch_deg = 0.0;
};

// The setup of each hidden effect's datasets (docs/validation.md, "Scenario effects").
SceneSetup sceneSetupFor(const std::string& effect);

// Writes a scenario of the RIT roof at `sceneFile` with the given effects and setup; the
// dataset's frames set the times.
void writeSceneScenario(const std::filesystem::path& file, const std::filesystem::path& sceneFile,
                        const SkyEffects& fx, const SceneSetup& setup);

// The parts of a generated scenario dataset other than its stimuli and frames, for the scenario
// already at d.scenario: the camera (`preset` with `settings`, whose width and height must be
// `width` × `height`), frame k at k · framePeriod_s, and the scene's renderer.
void prepareSceneDataset(Dataset& d, const std::string& preset, const sensor::Overrides& settings,
                         int width, int height, int frames, double framePeriod_s,
                         const SceneStimulusFactory& factory,
                         const std::filesystem::path& configDir);

Generated generateScene(const SceneGenSpec& spec, const SceneStimulusFactory& factory,
                        const std::filesystem::path& configDir);

}  // namespace nvs::fit
