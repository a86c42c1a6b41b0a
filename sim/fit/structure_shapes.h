#pragma once
// Internals of structure.cpp shared with structure_describe.cpp: the shapes the residual is
// tested for, the frames they work on, a shape's fit, and the finding's description.

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "sim/fit/effects.h"

namespace nvs::fit::shapes {

enum Kind {
    kSmoothGain,
    kFixedColumns,
    kFixedRows,
    kPointMirror,
    kLevel,
    kFrameGain,
    kFrameRows,
    kFrameShift,
    kLag,
    kKinds
};

struct Shape {
    const char* name;
    const char* character;
    bool perFrame;
    // Light before the photocathode, with its shot noise (a ghost, a gain over the frame), not
    // signal added after detection or a change between frames: the noise's re-test beside the
    // structure counts its mean signal in the model's (diagnose.cpp, demoteExplained).
    bool light;
    const char* what;
};

inline constexpr Shape kShapes[kKinds] = {
    {"smooth_gain", "spatial", false, true,
     "a gain that varies smoothly over the frame (vignetting, an uneven photocathode)"},
    {"fixed_columns", "spatial", false, false, "an offset fixed to each column"},
    {"fixed_rows", "spatial", false, false, "an offset fixed to each row"},
    {"point_mirror", "spatial", false, true,
     "a copy of the image rotated 180 deg about its centre (a ghost)"},
    {"level_transfer", "level", false, false, "a response that bends with the level"},
    {"frame_gain", "temporal", true, false, "a gain and an offset that change from frame to frame"},
    {"frame_rows", "temporal", true, false, "row offsets that change from frame to frame"},
    {"frame_shift", "geometric", true, false,
     "the image moving by part of a pixel from frame to frame"},
    {"lag", "temporal", false, false, "part of the previous frame's light carried into the next"},
};

// smooth_gain: 15 terms. The constant is there too: the baseline's gain acts after the
// model's saturation, a gain of the light before it (a vignetted frame's saturated spot keeps
// its level while the panels lose theirs).
constexpr int kLegendreDegree = 4;
constexpr int kLevelKnots = 10;  // level_transfer: hat functions over the predicted range
constexpr double kMirrorBlur_px = 4.0;
constexpr double kMinShare = 0.005;  // of the held-out squared error
// frame_gain's other bar: its gain's rms between frames of one stimulus. Where most pixels are
// dark the held-out error is the dark noise and a flicker's share of it is small: at 768 x 494
// a ±6.6 % flicker (4.1 % rms within a stimulus) scored z 7.4 and its folds agreed at z 6.6,
// but it took 0.42 % of the held-out squared error. A gain that changes by a percent from frame
// to frame is what a tracker sees, whatever the dark pixels' noise.
constexpr double kMinFrameGainRms = 0.01;
// point_mirror's only bar: the light in the copy, 1 % of the image's (its share of the error
// also holds the offset and gain fitted beside it, structure.cpp basis).
constexpr double kMinMirrorFraction = 0.01;
// point_mirror's coefficients: the copy's (sharp, blurred) first, then the offset and gain fitted
// beside it (structure.cpp, basis).
constexpr std::size_t kMirrorCopyTerms = 2;
// The light in point_mirror's copy, a fraction of the image's: its copy's coefficients summed.
inline double mirrorFraction(const std::vector<double>& coef) {
    return coef[0] + coef[1];
}
constexpr int kMaxStructures = 3;
constexpr double kRivalZ = 3.0;  // a shape this close is checked against the one taken

// The frames the shapes work on: residual, prediction and the regressors that are images.
struct Frames {
    int w = 0, h = 0;
    std::vector<Plane> R;   // measured − prediction [DC]; NaN where not valid
    std::vector<Plane> P;   // prediction b + a·Y [DC]
    std::vector<Plane> AY;  // a·Y [DC above offset]
    // a·dY/d(ln L): how the prediction moves when the light L changes by a factor (a gain of
    // the light, before the model's saturation and protection bend it); a·Y where the model
    // is linear.
    std::vector<Plane> G;
    double gain = 1.0;          // a, the baseline's gain
    std::vector<Plane> mirror;  // a·U rotated 180°, blurred by 1 px (and by 4 px: mirrorBlur)
    std::vector<Plane> mirrorBlur;
    std::vector<Plane> lag;      // a·(S_{k−1} − S_k), S the model's per-call signal
    std::vector<double> lx, ly;  // Legendre values per column and row, kLegendreDegree+1 each
    double levelLo = 0.0, levelHi = 1.0;
};

// A shape's prediction of the residual on every frame of the set.
struct ShapeFit {
    std::vector<Plane> Q;
    std::vector<double> coef;                   // fixed shapes
    std::vector<std::vector<double>> perFrame;  // per-frame shapes: each frame's parameters
    std::vector<Plane> within;   // temporal shapes: Q less its mean over frames of one stimulus
    double gainWithinRms = 0.0;  // frame_gain: rms of the gain less its stimulus's mean
    // Per-frame shapes: each frame's parameters fitted on each colour of the tiles' checkerboard
    // alone, and (temporal shapes) the z of their agreement between frames of one stimulus.
    std::vector<std::vector<double>> fold[2];
    double zFold = 0.0;
};

// level_transfer's knots, evenly spaced over the predicted range. (Knots denser toward the dark
// end, uniform in the square root of the level, followed a power law's slope there better but
// gave the model's own output a level structure at z 8.2 from its top knot, 3.1 DC at 147 DC,
// in 1 of 2 null datasets, and took a flicker for a level dependence.)
inline double knotLevel(double lo, double hi, int j) {
    return lo + (hi - lo) * static_cast<double>(j) / (kLevelKnots - 1);
}
// A number with `digits` decimals.
inline std::string fmt(int digits, double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.*f", digits, v);
    return b;
}

inline double rmsOf(const std::vector<double>& v) {
    double s = 0.0;
    for (double x : v)
        s += x * x;
    return v.empty() ? 0.0 : std::sqrt(s / static_cast<double>(v.size()));
}

// The finding's summary parameters, its cause line, and its curve or map in the report.
void describe(const Work& w, Kind k, const Frames& f, const ShapeFit& t, Finding& fd, Result& r);

}  // namespace nvs::fit::shapes
