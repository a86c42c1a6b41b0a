#pragma once
// Hidden-effect datasets (docs/design.md §9): from a seed, a random stimulus and a random strength
// of one or more catalog effects within a stated detectable range; the frames are simulated with
// the effects, and the dataset names the camera model without them.
//
// The camera: the thesis preset (pulnix-ag5745ef3) at a small frame size, with the model under
// test's phosphor reduced to its fast component and PRNU, smear and EBI off, so that each hidden
// effect is one the model lacks. Effects the chain implements are switched on in the chain that
// makes the frames (phosphor component, PRNU, smear, BSP, EBI, MCP noise factor); halo, veiling
// glare and MCP saturation, which it does not implement, are applied to the stimulus by
// diagnose's own forward models (effects.h), before the photocathode's shot noise.
//
// Stimulus: per hold block a background with a gradient, a few panels, a few bright points, all
// scaled by a random overall brightness (so the cathode current varies from block to block).

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sim/fit/dataset.h"

namespace nvs::fit {

struct GenSpec {
    std::vector<std::string> effects;  // empty: a null dataset
    std::uint64_t seed = 1;
    int width = 128, height = 96;
    int stimuli = 8;  // hold blocks
    int hold = 6;     // frames per block
};

struct Generated {
    Dataset data;
    // The hidden truth: "effect.parameter" → value, in the units diagnose reports.
    std::map<std::string, double> truth;
};

// The detectable range of each effect's strength (docs/validation.md, "diagnose").
struct EffectRange {
    const char* effect;
    const char* parameter;
    double lo, hi;
};
const std::vector<EffectRange>& effectRanges();

Generated generate(const GenSpec& spec, const std::filesystem::path& configDir);

// The frames the camera `cam` makes of seen[d.stimulusOfFrame[k]], in order, appended to
// d.frames (the chain's video output [DC]).
void makeFrames(const sensor::CameraParams& cam, std::uint64_t seed,
                const std::vector<ImageF>& seen, const std::filesystem::path& configDir,
                Dataset& d);

}  // namespace nvs::fit
