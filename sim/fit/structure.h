#pragma once
// What the catalog leaves (docs/diagnose.md §4b): after the catalog's effects are fitted, the
// residual (measured − predicted) is tested for structure of a few general shapes that no
// effect of the catalog has, each with its parameters fitted where they cannot see the frames
// they are scored on, and each reported as an `unexplained` finding with its character, its
// share of the held-out error, its z and its map or curve:
//
//   smooth_gain       spatial    the residual as Y·g(x, y), g a Legendre polynomial of degree
//                                4 in x and y (vignetting, a gain that varies over the frame)
//   fixed_columns     spatial    an offset per column (fixed pattern of the read-out)
//   fixed_rows        spatial    an offset per row
//   point_mirror      spatial    c·Y rotated 180° about the centre, sharp or blurred (a ghost
//                                from reflections between lens surfaces)
//   level_transfer    level      f(prediction), f piecewise linear in the predicted level (a
//                                non-linear response: compression, a knee)
//   frame_gain        temporal   a gain and an offset per frame (flicker, a drifting gain)
//   frame_rows        temporal   an offset per row and frame (row noise of the read-out)
//   frame_shift       geometric  α·∂Y/∂x + β·∂Y/∂y per frame (the image moving by part of a
//                                pixel: vibration, a grabber's line jitter)
//   lag               temporal   c·(S_{k−1} − S_k): part of the previous call's light carried
//
// Parameters of the fixed shapes are fitted on the calibration frames and scored on the
// held-out ones (paired test over tiles, docs/diagnose.md §2); the per-frame shapes, which
// the calibration frames cannot know, are fitted on half of each frame's tiles (a checkerboard)
// and scored on the other half, then the other way round. A structure counts at z ≥ zMin + 1
// and at least 0.5 % of the held-out squared error; the largest is taken, its prediction
// subtracted, and the rest tried again (at most three).
//
// A catalog finding is demoted to "candidate" when the residual after it holds a structure
// that explains more of the held-out error than the finding did (a mean effect), or when the
// noise test that named it no longer does once the structures are taken out of the measured
// frames (a noise effect: flicker, frame jitter and row noise raise the frame-to-frame
// variance that excess_noise and ebi_background measure; column offsets make a fixed pattern).

#include <vector>

#include "sim/fit/effects.h"

namespace nvs::fit {

// One structure found: its finding and what the correction of the measured frames needs.
struct StructureFit {
    Finding finding;
    int kind = 0;              // index into the shapes above (structure.cpp)
    std::vector<double> coef;  // a fixed shape's coefficients (per-frame shapes: none)
};

// The structures found in the residual of `cur` (effect "unexplained", best first); curves and
// maps of every structure found are added to r. frameGainShare, when given, receives the share
// of the held-out squared error that a free gain and offset per frame explain in the residual
// of `cur`, whether or not it changes between frames of one stimulus (a law of the frame's
// light, bright-source protection, is weighed against it: diagnose.cpp, demoteExplained).
std::vector<StructureFit> findStructure(Work& w, const Current& cur, Result& r,
                                        double* frameGainShare = nullptr);

// The measured frames (every frame of the dataset) with the structures found taken out, for
// the noise effects' second test. Frames are predicted by the model's mean signal with cur's
// gain and offset; per-frame shapes are fitted on each frame's every tile.
std::vector<Plane> withoutStructure(const Work& w, const Current& cur,
                                    const std::vector<StructureFit>& found);

// Whether a structure found is light before the photocathode, with its shot noise (the shape
// table's `light`, structure_shapes.h).
bool isLight(const StructureFit& s);
// The part of a light structure that is light: point_mirror's copy without the offset and gain
// fitted beside it (the baseline's share of the ghost, no light of the scene's).
StructureFit lightPart(StructureFit s);

}  // namespace nvs::fit
