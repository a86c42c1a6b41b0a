#pragma once
// Hidden scenario effects (DESIGN §9): datasets whose stimulus is rendered from a scenario.
// The truth renders the scene with a random strength of one scenario effect (lunar sky light
// scale, site pressure for refraction, cloud optical depth), the model under test is the same
// scenario without it. The scene is the thesis's RIT roof under a setting Moon: frames every few
// minutes for about three hours, from 23° down to the horizon (1998-09-02, the thesis's Table
// 4-2 night), so that the effects' dependence on the Moon's altitude shows.

#include <cstdint>
#include <filesystem>
#include <string>

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

// Writes a scenario of the RIT roof at `sceneFile` with the given effects, starting at
// utcStart; the dataset's frames set the times.
void writeSceneScenario(const std::filesystem::path& file, const std::filesystem::path& sceneFile,
                        const SkyEffects& fx, const std::string& utcStart);

Generated generateScene(const SceneGenSpec& spec, const SceneStimulusFactory& factory,
                        const std::filesystem::path& configDir);

}  // namespace nvs::fit
