#include "sim/sensor/stages/optics.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/core/simd.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

void OpticsParams::read(const PresetReader& root) {
    f_number = positive(root, "f_number", f_number);

    const PresetReader optics = root.sub("optics");
    focal_length_mm = positive(optics, "focal_length_mm", focal_length_mm);
    optics_transmission = positive(optics, "transmission", optics_transmission);
    require(optics_transmission <= 1.0, optics, "transmission", "must be <= 1");
    cos4 = optics.get<bool>("cos4", cos4);
    optics_fill_factor = positive(optics, "fill_factor", optics_fill_factor);
    require(optics_fill_factor <= 1.0, optics, "fill_factor", "must be <= 1");
    const std::string sa = optics.get<std::string>("solid_angle", "lens");
    if (sa == "lens")
        solid_angle = SolidAngleModel::Lens;
    else if (sa == "ccd_area")
        solid_angle = SolidAngleModel::CcdArea;
    else
        optics.fail("solid_angle", "must be lens or ccd_area");
    veiling_glare_index = optics.get<double>("veiling_glare_index", veiling_glare_index);
    require(veiling_glare_index >= 0.0 && veiling_glare_index < 0.5, optics, "veiling_glare_index",
            "must lie in [0, 0.5)");
}

namespace {

// Optics row: rate = Lpe·k with bad pixels as 0, k = onAxis/(1 + (r/f)²)² (cos⁴θ, r² from
// the column's and the row's parts); returns the bad count. The row sum is kept in 16 lanes
// (so that the loop vectorises) and added up in double.
NVS_SIMD_CLONES int opticsRowKernel(const float* __restrict in, const float* __restrict dx2,
                                    float dy2, float onAxis, float* __restrict out, int w,
                                    double* rowSum) noexcept {
    constexpr int kL = 16;
    float acc[kL] = {};
    int bad = 0;
    int x = 0;
    for (; x + kL <= w; x += kL) {
        for (int j = 0; j < kL; ++j) {
            const float v = in[x + j];
            // NaN fails both comparisons; +inf fails the second.
            const bool ok = (v >= 0.0f) & (v < 3.0e38f);
            bad += static_cast<int>(!ok);
            const float t = 1.0f + (dx2[x + j] + dy2);
            const float r = (ok ? v : 0.0f) * (onAxis / (t * t));
            out[x + j] = r;
            acc[j] += r;
        }
    }
    for (; x < w; ++x) {
        const float v = in[x];
        const bool ok = (v >= 0.0f) & (v < 3.0e38f);
        bad += static_cast<int>(!ok);
        const float t = 1.0f + (dx2[x] + dy2);
        const float r = (ok ? v : 0.0f) * (onAxis / (t * t));
        out[x] = r;
        acc[x % kL] += r;
    }
    double sum = 0.0;
    for (int j = 0; j < kL; ++j)
        sum += static_cast<double>(acc[j]);
    *rowSum = sum;
    return bad;
}

}  // namespace

// ---- 1. Optics ------------------------------------------------------------------------------

OpticsStage::OpticsStage(const CameraParams& c)
    : onAxis_(static_cast<float>(c.peRatePerLpe_on_axis())),
      glare_(static_cast<float>(c.veiling_glare_index)),
      pixels_(static_cast<double>(c.width) * c.height),
      dx2_(static_cast<std::size_t>(c.width), 0.0f),
      dy2_(static_cast<std::size_t>(c.height), 0.0f) {
    // cos⁴θ off axis: cos θ = f / sqrt(f² + r²), r the distance on the cathode, so
    // cos⁴θ = 1/(1 + (r/f)²)² with (r/f)² = (dx/f)² + (dy/f)², a column part and a row part.
    if (!c.cos4) return;
    const double px_m = c.pitch_x_um * 1e-6 * c.taper_magnification;
    const double py_m = c.pitch_y_um * 1e-6 * c.taper_magnification;
    const double f_m = c.focal_length_mm * 1e-3;
    const double cx = 0.5 * (c.width - 1);
    const double cy = 0.5 * (c.height - 1);
    for (int x = 0; x < c.width; ++x) {
        const double a = (x - cx) * px_m / f_m;
        dx2_[static_cast<std::size_t>(x)] = static_cast<float>(a * a);
    }
    for (int y = 0; y < c.height; ++y) {
        const double a = (y - cy) * py_m / f_m;
        dy2_[static_cast<std::size_t>(y)] = static_cast<float>(a * a);
    }
}

std::int64_t OpticsStage::apply(ImageView<const float> lpe, ImageView<float> rate,
                                FieldContext& ctx) const noexcept {
    std::int64_t bad = 0;
    double total = 0.0;
    for (int y = 0; y < lpe.height(); ++y) {
        double rowSum = 0.0;
        bad += applyRow(lpe.row(y), rate.row(y), y, rowSum);
        total += rowSum;
    }
    if (veiled()) {
        const double mean = veilMean(total);
        for (int y = 0; y < rate.height(); ++y)
            veilRow(rate.row(y), mean);
    }
    ctx.cathodeRate_pe_s += total;
    return bad;
}

void OpticsStage::veilRow(float* rate, double mean) const noexcept {
    const float keep = 1.0f - glare_;
    const float veil = static_cast<float>(static_cast<double>(glare_) * mean);
    const int w = static_cast<int>(dx2_.size());
    for (int x = 0; x < w; ++x)
        rate[x] = keep * rate[x] + veil;
}

int OpticsStage::applyRow(const float* lpe, float* rate, int y, double& rowSum) const noexcept {
    return opticsRowKernel(lpe, dx2_.data(), dy2_[static_cast<std::size_t>(y)], onAxis_, rate,
                           static_cast<int>(dx2_.size()), &rowSum);
}

}  // namespace nvs::sensor
