#include "sim/bolometer/stages/agc.h"

#include <algorithm>
#include <cmath>

#include "sim/bolometer/camera.h"

namespace nvs::bolometer {

void AgcParams::read(const Reader& root) {
    const Reader a = root.sub("agc");
    const std::string mode = a.get<std::string>("mode", "plateau");
    if (mode == "linear") {
        agc_mode = AgcMode::Linear;
    } else if (mode == "plateau") {
        agc_mode = AgcMode::Plateau;
    } else {
        a.fail("mode", "unknown AGC mode '" + mode + "' (linear, plateau)");
    }
    clip_low = fractionBelow(a, "clip_low", clip_low, 1.0);
    clip_high = fractionBelow(a, "clip_high", clip_high, 1.0 + 1e-12);
    require(clip_high > clip_low, a, "clip_high", "must be above clip_low");
    agc_time_constant_s = nonNegative(a, "time_constant_s", agc_time_constant_s);
    plateau_rel = positive(a, "plateau_rel", plateau_rel);
}

AgcStage::AgcStage(const ThermalCameraParams& cam)
    : mode_(cam.agc_mode),
      clipLow_(cam.clip_low),
      clipHigh_(cam.clip_high),
      alpha_(cam.agc_time_constant_s > 0.0
                 ? -std::expm1(-cam.framePeriod_s() / cam.agc_time_constant_s)
                 : 1.0),
      plateau_(static_cast<std::uint32_t>(std::max(
          1.0, std::round(cam.plateau_rel * cam.width * static_cast<double>(cam.height))))),
      pixels_(static_cast<std::uint64_t>(cam.width) * static_cast<std::uint64_t>(cam.height)),
      hist_(std::size_t{1} << cam.adc_bits),
      lut_(std::size_t{1} << cam.adc_bits) {}

void AgcStage::histogram(ImageView<const std::uint16_t> raw) noexcept {
    std::fill(hist_.begin(), hist_.end(), 0u);
    const std::size_t top = hist_.size() - 1;
    for (int y = 0; y < raw.height(); ++y) {
        const std::uint16_t* r = raw.row(y);
        for (int x = 0; x < raw.width(); ++x)
            ++hist_[std::min<std::size_t>(r[x], top)];
    }
}

void AgcStage::linearLut() noexcept {
    // The percentiles: the first bins whose cumulative count reaches clip·N.
    const double nLo = clipLow_ * static_cast<double>(pixels_);
    const double nHi = clipHigh_ * static_cast<double>(pixels_);
    double c = 0.0, pLo = -1.0, pHi = -1.0;
    for (std::size_t b = 0; b < hist_.size(); ++b) {
        c += hist_[b];
        if (pLo < 0.0 && c > nLo) pLo = static_cast<double>(b);
        if (pHi < 0.0 && c >= nHi) pHi = static_cast<double>(b);
    }
    if (pHi < 0.0) pHi = static_cast<double>(hist_.size() - 1);
    const double a = primed_ ? alpha_ : 1.0;
    primed_ = true;
    lo_ += a * (pLo - lo_);
    hi_ += a * (pHi - hi_);
    const double span = std::max(hi_ - lo_, 1.0);
    for (std::size_t b = 0; b < lut_.size(); ++b) {
        const double v = std::round(255.0 * (static_cast<double>(b) - lo_) / span);
        lut_[b] = static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
    }
}

void AgcStage::plateauLut() noexcept {
    std::size_t bMin = hist_.size(), bMax = 0;
    for (std::size_t b = 0; b < hist_.size(); ++b)
        if (hist_[b] != 0) {
            bMin = std::min(bMin, b);
            bMax = b;
        }
    if (bMin > bMax) bMin = bMax = 0;
    // C(b) = Σ_{b' ≤ b} min(h(b'), P); out = round(255·(C(b) − C(b_min))/(C(b_max) − C(b_min))).
    const std::uint64_t cMin = std::min(hist_[bMin], plateau_);
    std::uint64_t total = 0;
    for (std::size_t b = bMin; b <= bMax; ++b)
        total += std::min(hist_[b], plateau_);
    const double span = static_cast<double>(total - cMin);
    std::uint64_t c = 0;
    for (std::size_t b = 0; b < lut_.size(); ++b) {
        if (b >= bMin && b <= bMax) c += std::min(hist_[b], plateau_);
        const double num = b < bMin ? 0.0 : static_cast<double>(c - cMin);
        const double v = span > 0.0 ? std::round(255.0 * num / span) : 0.0;
        lut_[b] = static_cast<std::uint8_t>(std::clamp(v, 0.0, 255.0));
    }
    lo_ = static_cast<double>(bMin);
    hi_ = static_cast<double>(bMax);
}

void AgcStage::apply(ImageView<const std::uint16_t> raw, ImageView<std::uint8_t> out) noexcept {
    histogram(raw);
    if (mode_ == AgcMode::Linear) {
        linearLut();
    } else {
        plateauLut();
    }
    const std::size_t top = lut_.size() - 1;
    for (int y = 0; y < raw.height(); ++y) {
        const std::uint16_t* r = raw.row(y);
        std::uint8_t* o = out.row(y);
        for (int x = 0; x < raw.width(); ++x)
            o[x] = lut_[std::min<std::size_t>(r[x], top)];
    }
}

}  // namespace nvs::bolometer
