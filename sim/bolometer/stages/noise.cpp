#include "sim/bolometer/stages/noise.h"

#include <algorithm>
#include <bit>
#include <cmath>

#include "sim/bolometer/camera.h"
#include "sim/bolometer/stages/stage.h"
#include "sim/core/rng.h"
#include "sim/core/simd.h"

namespace nvs::bolometer {

void NoiseParams::read(const Reader& root) {
    const Reader n = root.sub("noise");
    netd_K = positive(n, "netd_K", netd_K);
    netd_reference_K = positive(n, "netd_reference_K", netd_reference_K);
    netd_f_number = positive(n, "netd_f_number", netd_f_number);
    row_rel = fractionBelow(n, "row_rel", row_rel, 1.0);
    column_rel = fractionBelow(n, "column_rel", column_rel, 1.0);
    require(row_rel * row_rel + column_rel * column_rel < 1.0, n, "column_rel",
            "row_rel² + column_rel² must be < 1 (they are parts of NETD)");
    flicker_rel = nonNegative(n, "flicker_rel", flicker_rel);
    flicker_octaves = n.get<int>("flicker_octaves", flicker_octaves);
    require(flicker_octaves >= 0 && flicker_octaves <= 24, n, "flicker_octaves",
            "must be in 0 … 24");
}

namespace {
// Planes of the temporal stream: per pixel white, the 1/f generator redrawn, per row, per
// column; the 1/f generators' first values from frame 0's planes kPlaneFlickerInit + j.
constexpr std::uint32_t kPlaneWhite = 0, kPlaneFlicker = 1, kPlaneRow = 2, kPlaneColumn = 3;
constexpr std::uint32_t kPlaneFlickerInit = 8;
}  // namespace

NoiseStage::NoiseStage(const ThermalCameraParams& cam, std::uint64_t seed)
    : seed_(seed), w_(cam.width), h_(cam.height) {
    const double s = cam.noiseVolts();
    sPx_ = static_cast<float>(
        s * std::sqrt(1.0 - cam.row_rel * cam.row_rel - cam.column_rel * cam.column_rel));
    sRow_ = static_cast<float>(s * cam.row_rel);
    sCol_ = static_cast<float>(s * cam.column_rel);
    const std::size_t n = static_cast<std::size_t>((std::max(w_, h_) + 3) / 4 * 4);
    words_.resize(n);
    z_.resize(n);
    rowZ_.resize(n);
    colZ_.resize(n);
    const int m = cam.flicker_rel > 0.0 ? cam.flicker_octaves : 0;
    sFlicker_ = m > 0 ? static_cast<float>(cam.flicker_rel * s / std::sqrt(m)) : 0.0f;
    if (m == 0) return;
    flickerSum_ = ImageF(w_, h_);
    for (int j = 0; j < m; ++j) {
        flicker_.emplace_back(w_, h_);
        for (int y = 0; y < h_; ++y) {
            drawNormals(0, static_cast<std::uint32_t>(y), kPlaneFlickerInit + j, w_);
            float* g = flicker_[j].row(y);
            float* sum = flickerSum_.row(y);
            for (int x = 0; x < w_; ++x) {
                g[x] = sFlicker_ * z_[x];
                sum[x] += g[x];
            }
        }
    }
}

void NoiseStage::drawNormals(std::uint64_t frame, std::uint32_t y, std::uint32_t plane,
                             int n) noexcept {
    const PixelRng rng(RngKey{seed_, kStreamTemporal}, frame);
    rng.rowWords(y, plane, 0, (n + 3) / 4, words_.data());
    normalsFromWords(words_.data(), z_.data(), n);
}

void NoiseStage::beginFrame(std::uint64_t frame) noexcept {
    frame_ = frame;
    drawNormals(frame, 0, kPlaneRow, h_);
    std::copy(z_.begin(), z_.begin() + h_, rowZ_.begin());
    drawNormals(frame, 0, kPlaneColumn, w_);
    for (int x = 0; x < w_; ++x)
        colZ_[x] = sCol_ * z_[x];
    // Voss–McCartney: frame k redraws generator ctz(k + 1) (none past the last).
    const int j = std::countr_zero(frame + 1);
    redraw_ = j < static_cast<int>(flicker_.size()) ? j : -1;
}

NVS_SIMD_CLONES void NoiseStage::applyRow(int y, float* v) noexcept {
    const std::uint32_t row = static_cast<std::uint32_t>(y);
    if (redraw_ >= 0) {
        // Uniform values of σ_v (Voss's dice): √12·σ_v·(w − 2³¹)·2⁻³², w − 2³¹ being the word
        // with its top bit flipped read as signed; one word, no normal transform (the sum of M
        // is near-normal anyway).
        const PixelRng rng(RngKey{seed_, kStreamTemporal}, frame_);
        rng.rowWords(row, kPlaneFlicker, 0, (w_ + 3) / 4, words_.data());
        const float scale = sFlicker_ * 3.4641016f * 0x1.0p-32f;  // √12·σ_v·2⁻³²
        float* g = flicker_[redraw_].row(y);
        float* sum = flickerSum_.row(y);
        for (int x = 0; x < w_; ++x) {
            const float nv =
                scale * static_cast<float>(static_cast<std::int32_t>(words_[x] ^ 0x80000000u));
            sum[x] += nv - g[x];
            g[x] = nv;
        }
    }
    drawNormals(frame_, row, kPlaneWhite, w_);
    const float r = sRow_ * rowZ_[y];
    if (flicker_.empty()) {
        for (int x = 0; x < w_; ++x)
            v[x] += sPx_ * z_[x] + r + colZ_[x];
    } else {
        const float* sum = flickerSum_.row(y);
        for (int x = 0; x < w_; ++x)
            v[x] += sPx_ * z_[x] + r + colZ_[x] + sum[x];
    }
}

void NoiseStage::apply(ImageView<float> volts, std::uint64_t frame) noexcept {
    beginFrame(frame);
    for (int y = 0; y < h_; ++y)
        applyRow(y, volts.row(y));
}

}  // namespace nvs::bolometer
