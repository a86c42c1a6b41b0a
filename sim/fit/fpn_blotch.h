#pragma once
// The effect fixed_pattern_noise: a pattern of pixel gains fixed to the sensor, as two members.
// Cell by cell (the first): the covariance per tile of two residual averages. In blotches of a
// correlation length (the second): that tile covariance takes each tile's mean out, so a pattern
// whose blotches are as large as a tile (8-16 px) falls mostly in the tile means and is not
// seen: the open world's blotchy PRNU (σ 5-20 px, 3-8 % rms) came back as unexplained smooth
// gain or not at all, 0 of 3. The second member is measured by its covariance at several lags.

#include <vector>

#include "sim/fit/effects.h"
#include "sim/fit/engine.h"

namespace nvs::fit {

// The residual of the frames [i0, i1) of w.sub against the current model, summed in two
// groups with no field and, where there are two or more, no stimulus in common
// (fixedPattern): a pattern fixed to the sensor is in both groups, the temporal noise is not.
struct PatternGroups {
    Plane A[2], Y[2];             // Σ residual [DC], Σ model signal [model DC] per pixel
    std::vector<float> count[2];  // frames summed per pixel
    Plane stimulus;               // the model's signal averaged over every frame (none left out)
};
PatternGroups patternGroups(const Work& w, const Current& cur, std::size_t i0, std::size_t i1);

// The member fitted on the calibration frames and scored on the held-out ones.
struct BlotchMember {
    bool valid = false;
    const char* why = "";
    double white_rel = 0.0;        // the cell-by-cell part, rms
    double blotch_rel = 0.0;       // the blotches, rms
    double blotch_sigma_px = 0.0;  // their low-pass σ (autocorrelation exp(−r²/4σ²))
    Score vsModel;                 // held-out: the model's pattern → the member
    Score vsWhite;                 // held-out: cell by cell only (refitted) → the member
};
BlotchMember fitBlotchMember(const Work& w, const Current& cur);

// The effect fixed_pattern_noise: the covariance per tile of two residual averages that share no
// field is the pattern fixed to the sensor (EMVA 1288's DSNU and PRNU); the PRNU fitted on the
// calibration frames against the model's, scored on the held-out ones, and the blotchy member
// where it beats it. Adds the calibration residual map to res and the DSNU/PRNU split to its
// baseline.
Candidate fixedPatternNoise(const Work& w, const Current& cur, Result& res);

}  // namespace nvs::fit
