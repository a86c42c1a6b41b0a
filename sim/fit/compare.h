#pragma once
// The gain of a fix (`nvstim diagnose DATASET --compare A B`, docs/diagnose.md §7): two camera
// presets (two models), each fitted to the dataset on its calibration half exactly as the
// diagnosis fits its baseline (extra MTF blur, gain and offset; the preset's own effects on),
// then both scored on the held-out half on the same pixels:
//   - held-out RMS of measured − predicted [DC];
//   - the Gaussian log-likelihood per pixel, each model with its own noise (the variance of its
//     noisy run as a line in its signal), so a model that predicts the mean and the noise better
//     scores higher;
//   - per region: a 3 × 3 grid of the frame, three bands of the predicted level (dark, middle and
//     bright thirds of model A's range) and the dataset's [[roi]]s, the RMS of each model and the
//     gain 100·(1 − RMS_B / RMS_A) %;
//   - the paired test over tiles of B's squared error against A's (z > 0: B predicts better).

#include <filesystem>
#include <string>
#include <vector>

#include "sim/fit/diagnose.h"

namespace nvs::fit {

struct ModelFit {
    std::string preset;  // as given
    double gain_rel = 1.0, offset_dc = 0.0, blur_px = 0.0;
    double heldoutRms_dc = 0.0;          // over the pixels both models score
    double logLikelihoodPerPixel = 0.0;  // mean over those pixels [nats]
    std::vector<double> regionRms_dc;    // per Comparison::regions
};

struct Comparison {
    ModelFit a, b;
    std::vector<std::string> regions;
    std::vector<double> regionPixels;    // held-out pixel count per region
    std::vector<double> regionGain_pct;  // 100·(1 − rms_b / rms_a)
    double z = 0.0;                      // paired test over tiles, B against A
    double pixels = 0.0;                 // held-out pixels scored
};

// Throws SetupError for a preset that cannot be loaded.
// The dataset's [camera.settings] apply to both presets, unless settingsB is given for B (the
// written preset of a diagnosis: the settings of the tables its findings set are left out, or a
// dataset that switches a stage off would switch off what the finding switched on).
Comparison compareModels(const Dataset& d, const std::filesystem::path& configDir,
                         const std::string& presetA, const std::string& presetB,
                         const Options& opt = {}, const Progress& progress = {},
                         const sensor::Overrides* settingsB = nullptr);

// The dataset's settings without those of the tables the named findings' preset keys set.
sensor::Overrides settingsWithoutFindings(const Dataset& d, const Result& r);

// {"compare":{"a":{...},"b":{...},"regions":[{"name","pixels","rms_a_dc","rms_b_dc",
// "gain_pct"}],"z","heldout_pixels"}} on one line.
std::string toJson(const Comparison& c);

}  // namespace nvs::fit
