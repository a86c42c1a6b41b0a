#pragma once
// Slanted-edge spatial frequency response (ISO 12233:2014 §D, "e-SFR"): locate the edge in
// every row by the centroid of the row's derivative, fit a line through the centroids,
// project every pixel onto the edge normal into 4× oversampled bins (the edge spread
// function), differentiate, apply a Hamming window, and take the DFT's modulus. The
// finite-difference derivative and the bin width are divided out (the ISO correction).
// Written here because no Debian package provides it.

#include <vector>

#include "sim/core/image.h"

namespace nvs::sensor {

struct SfrResult {
    std::vector<double> frequency_cyc_px;  // along the edge normal, cycles per pixel
    std::vector<double> sfr;               // normalised to 1 at zero frequency
    double edgeAngle_rad = 0.0;            // of the edge from vertical
};

// roi: a near-vertical edge (|angle| ≤ ~10°) crossing every row. Throws SetupError on an
// ROI with no edge.
SfrResult slantedEdgeSfr(ImageView<const float> roi);
// Linear interpolation of the SFR at f.
double sfrAt(const SfrResult& r, double f_cyc_px);

}  // namespace nvs::sensor
