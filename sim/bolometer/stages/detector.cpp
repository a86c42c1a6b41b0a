#include "sim/bolometer/stages/detector.h"

#include <cmath>

#include "sim/bolometer/camera.h"
#include "sim/core/simd.h"

namespace nvs::bolometer {

void DetectorParams::read(const Reader& root) {
    const Reader d = root.sub("detector");
    time_constant_s = positive(d, "time_constant_s", time_constant_s);
    responsivity_V_W = positive(d, "responsivity_V_W", responsivity_V_W);
}

DetectorStage::DetectorStage(const ThermalCameraParams& cam)
    : keep_(static_cast<float>(std::exp(-cam.framePeriod_s() / cam.time_constant_s))),
      responsivity_(static_cast<float>(cam.responsivity_V_W)),
      lag_W_(cam.width, cam.height) {}

float DetectorStage::beginFrame() noexcept {
    const float keep = primed_ ? keep_ : 0.0f;
    primed_ = true;
    return keep;
}

NVS_SIMD_CLONES void DetectorStage::applyRow(int y, const float* p, float* v, float keep) noexcept {
    // P̄_k = P_k + (P̄_{k−1} − P_k)·e^(−Δt/τ); V = R·P̄_k.
    float* s = lag_W_.row(y);
    for (int x = 0; x < lag_W_.width(); ++x) {
        s[x] = p[x] + (s[x] - p[x]) * keep;
        v[x] = s[x] * responsivity_;
    }
}

void DetectorStage::apply(ImageView<const float> power_W, ImageView<float> volts) noexcept {
    const float keep = beginFrame();
    for (int y = 0; y < lag_W_.height(); ++y)
        applyRow(y, power_W.row(y), volts.row(y), keep);
}

}  // namespace nvs::bolometer
