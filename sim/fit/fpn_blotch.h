#pragma once
// The fixed pattern's second member (fixed_pattern_noise): gains that vary in blotches of a
// correlation length, not cell by cell. noise.cpp's tile covariance takes each tile's mean out,
// so a pattern whose blotches are as large as a tile (8-16 px) falls mostly in the tile means
// and is not seen: the open world's blotchy PRNU (σ 5-20 px, 3-8 % rms) came back as
// unexplained smooth gain or not at all, 0 of 3. Here the pattern is measured by its
// covariance at several lags.

#include <vector>

#include "sim/fit/effects.h"
#include "sim/fit/engine.h"

namespace nvs::fit {

// The residual of the frames [i0, i1) of w.sub against the current model, summed in two
// groups with no field and, where there are two or more, no stimulus in common (noise.cpp,
// fixedPattern): a pattern fixed to the sensor is in both groups, the temporal noise is not.
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

}  // namespace nvs::fit
