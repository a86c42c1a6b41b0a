#include "rt/synth/synth.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/core/units.h"

namespace nvs::rt {

void TestPatternRender::render(const FrameRequest& req, RadianceTarget out,
                               FrameMeta& meta) noexcept {
    const ImageView<float> radiance = out.band_W_m2_sr;
    const int w = radiance.width();
    const int h = radiance.height();
    const int barRows = 3 * h / 4;
    for (int y = 0; y < barRows; ++y) {
        float* row = radiance.row(y);
        for (int x = 0; x < w; ++x) {
            const int bar = std::min(7, x * 8 / w);
            row[x] = static_cast<float>(lMax_ * bar / 7.0);
        }
    }
    // Pose strip: heading as a bar length.
    double yawFrac = std::fmod(req.platform.yaw_rad, kTwoPi) / kTwoPi;
    if (yawFrac < 0.0) yawFrac += 1.0;
    const int yawEnd = static_cast<int>(std::floor(yawFrac * w));
    const float half = static_cast<float>(0.5 * lMax_);
    for (int y = barRows; y < h; ++y) {
        float* row = radiance.row(y);
        for (int x = 0; x < w; ++x)
            row[x] = x < yawEnd ? half : 0.0f;
    }
    // Moving target, tagged as object 1.
    const int side = std::max(2, h / 8);
    const int span = std::max(1, w - side);
    const double travel = std::fmod(speed_px_s_ * req.t_sample_s, static_cast<double>(span));
    const int x0 =
        std::clamp(static_cast<int>(std::floor(travel < 0 ? travel + span : travel)), 0, span - 1);
    const int y0 = std::max(0, h - side);
    const float lMax = static_cast<float>(lMax_);
    for (int y = y0; y < h; ++y) {
        float* row = radiance.row(y);
        for (int x = x0; x < std::min(w, x0 + side); ++x)
            row[x] = lMax;
    }
    meta.truthCount = 1;
    meta.truth[0] =
        TruthBox{1, static_cast<float>(x0), static_cast<float>(y0),
                 static_cast<float>(std::min(side, w - x0)), static_cast<float>(h - y0)};
    meta.truth[0].truncated = x0 + side > w;
    std::memcpy(meta.truth[0].cls, "block", sizeof "block");
}

void LinearCamera::expose(const FrameRequest& /*req*/, RadianceFrame in,
                          ImageView<std::uint16_t> counts, FieldMeta& /*applied*/) noexcept {
    const ImageView<const float> radiance = in.band_W_m2_sr;
    const float maxCount = static_cast<float>((1u << bits_) - 1u);
    quantize<std::uint16_t>(radiance, counts,
                            static_cast<float>(static_cast<double>(maxCount) / fullScale_), 0.0f);
    // quantize clamps to the type's range; clamp to the ADC's.
    if (bits_ < 16) {
        const auto cap = static_cast<std::uint16_t>(maxCount);
        for (int y = 0; y < counts.height(); ++y) {
            std::uint16_t* row = counts.row(y);
            for (int x = 0; x < counts.width(); ++x)
                row[x] = std::min(row[x], cap);
        }
    }
}

void HeldPlatform::sample(double t_sample_s, double /*now_s*/, PlatformState& out) noexcept {
    out = state_;
    out.t_sample_s = t_sample_s;
    out.utc_unix_s = state_.utc_unix_s + t_sample_s;
    out.telemetryRx_s = -1.0;
}

}  // namespace nvs::rt
