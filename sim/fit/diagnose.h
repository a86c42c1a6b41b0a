#pragma once
// `nvstim diagnose` (docs/design.md §8): fit the camera model to a measured dataset, then try each
// effect of the catalog that the model lacks, and name the ones that improve the prediction of
// held-out frames by more than chance and their extra parameters can explain.
//
// 1. Simulate the stimulus with the model (model.h): the mean frames and the model's own noise.
// 2. Split the frames in time: the first half calibrates, the second half is held out.
// 3. Baseline on the calibration half: video gain and offset (least squares), an extra Gaussian
//    blur for the MTF, the signal-independent noise; the EMVA 1288 quantities (Release 4.0,
//    Linear: photon transfer σ²_y − σ²_y.dark = K(μ_y − μ_y.dark), DSNU, PRNU, linearity error).
// 4. Each effect: its forward model (effects.cpp) with its parameters fitted on the
//    calibration half, scored on the held-out half tile by tile (paired z over tiles) with a
//    penalty of k·ln(tiles) for its k parameters (BIC). Significant effects are taken greedily,
//    best first, and the rest tried again on top of them.
// 5. Findings: name, parameters in preset units, held-out RMS before and after, confidence.

#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sim/fit/dataset.h"

namespace nvs::fit {

// The effect catalog (docs/contracts.md): the names are a contract.
inline const char* const kEffectNames[] = {"phosphor_persistence",
                                           "halo",
                                           "fixed_pattern_noise",
                                           "mcp_saturation",
                                           "bright_source_protection",
                                           "veiling_glare",
                                           "vertical_smear",
                                           "ebi_background",
                                           "excess_noise",
                                           "lunar_sky_scatter",
                                           "refraction",
                                           "cloud_transmission"};

struct Finding {
    std::string effect;
    std::string cause;                                       // one line an engineer reads
    std::vector<std::pair<std::string, double>> parameters;  // preset units in the key names
    double heldoutRmsBefore = 0.0;
    double heldoutRmsAfter = 0.0;
    double confidence = 0.0;  // Φ(z) of the held-out paired test
    double z = 0.0;           // paired held-out z over tiles
    double score = 0.0;       // z² − k·ln(tiles): > 0 to count
    std::string observable;   // what heldout_rms measures
    std::string unit;         // its unit (DC or DC2)
    // Preset keys that switch the effect on: "section.key" = TOML value text.
    std::vector<std::pair<std::string, std::string>> presetKeys;
    // "named", or "candidate" where the residual after it holds a larger unexplained structure,
    // or its noise test fails once the structures are taken out (structure.h).
    std::string status = "named";
    // effect "unexplained" only: the structure's shape, its character (spatial, temporal,
    // level, geometric) and its share of the held-out squared error.
    std::string structure, character;
    double share = 0.0;
};

// Per-effect outcome, significant or not (the report lists every one).
struct Trial {
    std::string effect;
    bool tried = false;
    std::string why;  // why not tried, or the fitted values
    double z = 0.0, score = 0.0, before = 0.0, after = 0.0;
};

// Curves for the report (photon transfer, linearity, before/after, the effect's signature).
struct Curve {
    std::string name, xLabel, yLabel;
    std::vector<std::string> series;        // series names
    std::vector<std::vector<double>> x, y;  // one x/y vector per series
};

struct Result {
    std::map<std::string, double> baseline;  // fitted baseline and EMVA 1288 quantities
    std::vector<Finding> findings;           // best first
    std::vector<Trial> trials;
    std::vector<Curve> curves;
    // Images for the report: name → plane (width × height).
    std::vector<std::pair<std::string, Plane>> maps;
    int width = 0, height = 0;
    std::string camera;
};

struct Options {
    std::uint64_t seed = 1;
    double zMin = 4.0;          // one-sided held-out z a finding needs
    int maxFramesPerSplit = 0;  // 0: from the frame size (bounded work per trial)
    int maxRounds = 4;          // greedy rounds
};

Result diagnose(const Dataset& d, const std::filesystem::path& configDir, const Options& opt = {},
                const Progress& progress = {});

// The contract's JSON: {"baseline":{...},"findings":[{...}]} on one line.
std::string toJson(const Result& r);

// Everything the report draws, as one JSON object: baseline, findings (with causes), every
// effect's trial, the curves; the maps are written beside it as PFM by the caller.
std::string reportJson(const Result& r, const std::string& dataset);

// The preset text with every finding's keys set (tables added or keys replaced), from the
// preset file the dataset names; with a header comment saying what was fitted.
std::string presetWithFindings(const std::filesystem::path& presetFile, const Result& r);

}  // namespace nvs::fit
