#include "sim/sensor/stages/halo.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/core/simd.h"
#include "sim/core/units.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

void HaloParams::read(const PresetReader& root) {
    const PresetReader halo = root.sub("halo");
    halo_enabled = halo.get<bool>("enabled", halo_enabled);
    halo_fraction = nonNegative(halo, "fraction", halo_fraction);
    require(halo_fraction < 1.0, halo, "fraction", "must be below 1");
    halo_gap_um = positive(halo, "gap_um", halo_gap_um);
    halo_radius_um = nonNegative(halo, "radius_um", halo_radius_um);
}

namespace {

// Halo (HaloStage), in vector clones like the other row loops; each output element is
// computed by itself, in the same order in every clone.
// Cell sums of one pixel row: c[cx] += Σ_k r[cx·kBlock + k] over the whole cells.
template <int B>
inline __attribute__((always_inline)) void haloCellSumsBody(const float* __restrict r,
                                                            float* __restrict c,
                                                            int cells) noexcept {
    for (int cx = 0; cx < cells; ++cx) {
        float acc = 0.0f;
        for (int k = 0; k < B; ++k)
            acc += r[cx * B + k];
        c[cx] += acc;
    }
}
NVS_SIMD_CLONES void haloCellSums4(const float* r, float* c, int cells) noexcept {
    haloCellSumsBody<4>(r, c, cells);
}
// out[i] += k·src[i]: one tap of the halo's disk over a row of cells.
NVS_SIMD_CLONES void haloTapKernel(float* __restrict out, const float* __restrict src, float k,
                                   int n) noexcept {
    for (int i = 0; i < n; ++i)
        out[i] += k * src[i];
}
// A pixel row back from its cells: r = keep·r + share·spread of its cell.
// In place (out = r) or into another row (the image row read, not written back).
template <int B>
inline __attribute__((always_inline)) void haloAddBackBody(const float* r, float* out,
                                                           const float* __restrict sp, int cells,
                                                           float keep, float share) noexcept {
    for (int cx = 0; cx < cells; ++cx) {
        const float add = share * sp[cx];
        for (int k = 0; k < B; ++k)
            out[cx * B + k] = keep * r[cx * B + k] + add;
    }
}
NVS_SIMD_CLONES void haloAddBack4(float* r, const float* sp, int cells, float keep,
                                  float share) noexcept {
    haloAddBackBody<4>(r, r, sp, cells, keep, share);
}
NVS_SIMD_CLONES void haloAddBack4To(const float* __restrict r, float* __restrict out,
                                    const float* sp, int cells, float keep, float share) noexcept {
    haloAddBackBody<4>(r, out, sp, cells, keep, share);
}

}  // namespace

// ---- 3b. Halo ------------------------------------------------------------------------------

HaloStage::HaloStage(const CameraParams& c)
    : enabled_(c.halo_enabled && c.halo_fraction > 0.0), w_(c.width), h_(c.height) {
    if (!enabled_) return;
    fraction_ = static_cast<float>(c.halo_fraction);
    cw_ = (w_ + kBlock - 1) / kBlock;
    ch_ = (h_ + kBlock - 1) / kBlock;
    // Cell size at the cathode [µm] (the CCD pitch seen through the taper).
    const double cx_um = kBlock * c.pitch_x_um * c.taper_magnification;
    const double cy_um = kBlock * c.pitch_y_um * c.taper_magnification;
    const double r_um = c.haloRadius_um();
    kr_ = static_cast<int>(std::ceil(r_um / std::min(cx_um, cy_um)));
    const int n = 2 * kr_ + 1;
    kernel_.assign(static_cast<std::size_t>(n) * n, 0.0f);
    // Each cell's weight: the ring density integrated over the cell, 8×8 samples a cell; the
    // density's integrable rim singularity is held at r/R ≤ 0.999.
    constexpr int kSub = 8;
    double total = 0.0;
    std::vector<double> wsum(kernel_.size(), 0.0);
    for (int j = -kr_; j <= kr_; ++j)
        for (int i = -kr_; i <= kr_; ++i) {
            double acc = 0.0;
            for (int b = 0; b < kSub; ++b)
                for (int a = 0; a < kSub; ++a) {
                    const double x = (i + (a + 0.5) / kSub - 0.5) * cx_um;
                    const double y = (j + (b + 0.5) / kSub - 0.5) * cy_um;
                    const double u = std::hypot(x, y) / r_um;
                    if (u >= 1.0) continue;
                    // p(r) dr ∝ dr/√(1 − u²); per area: divide by 2πr.
                    acc += 1.0 / (std::sqrt(1.0 - std::min(u, 0.999) * std::min(u, 0.999)) *
                                  std::max(u, 0.5 / kSub));
                }
            wsum[static_cast<std::size_t>((j + kr_) * n + (i + kr_))] = acc;
            total += acc;
        }
    for (std::size_t k = 0; k < kernel_.size(); ++k)
        kernel_[k] = static_cast<float>(wsum[k] / total);
    cells_ = ImageF(cw_, ch_);
    spread_ = ImageF(cw_, ch_);
}

void HaloStage::apply(ImageView<float> rate) noexcept {
    SerialExecutor serial;
    apply(rate, serial);
}

void HaloStage::apply(ImageView<float> rate, RowExecutor& exec) noexcept {
    if (!enabled_) return;
    const ImageView<const float> in(rate.row(0), rate.width(), rate.height(), rate.stride_px());
    auto cells = [&](int b) { sumCells(in, bandStart(b, ch_), bandStart(b + 1, ch_)); };
    forEachIndex(exec, kChainSlots, cells);
    spread(exec);
    auto back = [&](int b) {
        for (int y = bandStart(b, h_); y < bandStart(b + 1, h_); ++y)
            addBackRow(rate.row(y), y);
    };
    forEachIndex(exec, kChainSlots, back);
}

// The loops run along rows with the column index innermost and no division, so that they
// vectorise (this stage is on every field's path).
static_assert(HaloStage::kBlock == 4, "haloCellSums4 and haloAddBack4 are for cells of 4 pixels");

void HaloStage::sumCells(ImageView<const float> rate, int cy0, int cy1) noexcept {
    // 1. Sum the rate over each cell: a cell row from its kBlock pixel rows, top to bottom.
    const int fullCells = w_ / kBlock;  // cells of kBlock whole pixels; the last may be partial
    for (int cy = cy0; cy < cy1; ++cy) {
        float* c = cells_.row(cy);
        std::fill(c, c + cw_, 0.0f);
        for (int y = cy * kBlock; y < std::min(h_, (cy + 1) * kBlock); ++y) {
            const float* r = rate.row(y);
            haloCellSums4(r, c, fullCells);
            for (int x = fullCells * kBlock; x < w_; ++x)
                c[fullCells] += r[x];
        }
    }
}

void HaloStage::spread(RowExecutor& exec) noexcept {
    // 2. Spread each cell over the disk (cells off the image are lost: the halo's share of
    // light near the border leaves the frame, as on the tube): out(cx, cy) = Σ_ij
    // K(i, j)·cells(cx − i, cy − j), one kernel tap at a time over a whole row of cells.
    const int n = 2 * kr_ + 1;
    auto rows = [&](int b) {
        for (int cy = bandStart(b, ch_); cy < bandStart(b + 1, ch_); ++cy) {
            float* out = spread_.row(cy);
            std::fill(out, out + cw_, 0.0f);
            for (int j = -kr_; j <= kr_; ++j) {
                const int sy = cy - j;
                if (sy < 0 || sy >= ch_) continue;
                const float* src = cells_.row(sy);
                for (int i = -kr_; i <= kr_; ++i) {
                    const float k = kernel_[static_cast<std::size_t>((j + kr_) * n + (i + kr_))];
                    if (k == 0.0f) continue;
                    const int x0 = std::max(0, i), x1 = std::min(cw_, cw_ + i);
                    if (x1 > x0) haloTapKernel(out + x0, src + (x0 - i), k, x1 - x0);
                }
            }
        }
    };
    forEachIndex(exec, kChainSlots, rows);
}

void HaloStage::addBackRow(float* r, int y) noexcept {
    addBackRow(r, r, y);
}

void HaloStage::addBackRow(const float* r, float* out, int y) noexcept {
    // 3. Back onto the pixels: a cell's halo share evenly over its pixels.
    const int fullCells = w_ / kBlock;
    const float keep = 1.0f - fraction_;
    const float share = fraction_ / static_cast<float>(kBlock * kBlock);
    const float* sp = spread_.row(y / kBlock);
    if (r == out)
        haloAddBack4(out, sp, fullCells, keep, share);
    else
        haloAddBack4To(r, out, sp, fullCells, keep, share);
    for (int x = fullCells * kBlock; x < w_; ++x)
        out[x] = keep * r[x] + share * sp[fullCells];
}

}  // namespace nvs::sensor
