#include "sim/bolometer/stages/focal_plane.h"

#include <cmath>
#include <vector>

#include "sim/bolometer/camera.h"
#include "sim/bolometer/stages/stage.h"
#include "sim/core/rng.h"
#include "sim/core/simd.h"

namespace nvs::bolometer {

void FocalPlaneParams::read(const Reader& root) {
    const Reader f = root.sub("focal_plane");
    ambient_K = positive(f, "ambient_K", ambient_K);
    self_heating_K = nonNegative(f, "self_heating_K", self_heating_K);
    self_heating_time_s = positive(f, "self_heating_time_s", self_heating_time_s);
    drift_K_s = f.get<double>("drift_K_s", drift_K_s);
    require(std::isfinite(drift_K_s) && std::abs(drift_K_s) <= 1.0, f, "drift_K_s",
            "must be within ±1 K/s");
    offset_nonuniformity_K = nonNegative(f, "offset_nonuniformity_K", offset_nonuniformity_K);
    gain_nonuniformity_rel =
        fractionBelow(f, "gain_nonuniformity_rel", gain_nonuniformity_rel, 0.2);
    offset_drift_K_per_K = nonNegative(f, "offset_drift_K_per_K", offset_drift_K_per_K);
}

double FocalPlaneParams::fpaTemperature_K(double t_s) const {
    return ambient_K + drift_K_s * t_s + self_heating_K * -std::expm1(-t_s / self_heating_time_s);
}

FocalPlaneStage::FocalPlaneStage(const ThermalCameraParams& cam, std::uint64_t seed)
    : ambient_K_(cam.ambient_K),
      gain_(cam.width, cam.height),
      offset_V_(cam.width, cam.height),
      drift_V_K_(cam.width, cam.height) {
    // Three planes of one normal per pixel, frame 0: the same maps in every frame.
    const PixelRng rng(RngKey{seed, kStreamPattern}, 0);
    const double vPerK = cam.voltsPerSceneK(cam.netd_reference_K);
    const int w = cam.width;
    std::vector<std::uint32_t> words(static_cast<std::size_t>((w + 3) / 4 * 4));
    std::vector<float> z(words.size());
    ImageF* maps[3] = {&gain_, &offset_V_, &drift_V_K_};
    const double scale[3] = {cam.gain_nonuniformity_rel, cam.offset_nonuniformity_K * vPerK,
                             cam.offset_drift_K_per_K * vPerK};
    for (std::uint32_t plane = 0; plane < 3; ++plane)
        for (int y = 0; y < cam.height; ++y) {
            rng.rowWords(static_cast<std::uint32_t>(y), plane, 0, (w + 3) / 4, words.data());
            normalsFromWords(words.data(), z.data(), w);
            float* m = maps[plane]->row(y);
            for (int x = 0; x < w; ++x)
                m[x] = static_cast<float>(scale[plane] * static_cast<double>(z[x]));
        }
    // Each map's own mean is taken off: the factory calibration sets the mean gain and level,
    // and the temperature compensation the mean drift; what remains is the pattern.
    for (ImageF* map : maps) {
        double sum = 0.0;
        for (int y = 0; y < cam.height; ++y)
            for (int x = 0; x < w; ++x)
                sum += static_cast<double>((*map)(x, y));
        const float mean = static_cast<float>(sum / (static_cast<double>(w) * cam.height));
        const float base = map == &gain_ ? 1.0f : 0.0f;
        for (int y = 0; y < cam.height; ++y)
            for (int x = 0; x < w; ++x)
                (*map)(x, y) += base - mean;
    }
}

NVS_SIMD_CLONES void FocalPlaneStage::applyRow(int y, float* v, float dT) const noexcept {
    const float* g = gain_.row(y);
    const float* o = offset_V_.row(y);
    const float* c = drift_V_K_.row(y);
    for (int x = 0; x < gain_.width(); ++x)
        v[x] = g[x] * v[x] + o[x] + c[x] * dT;
}

void FocalPlaneStage::apply(ImageView<float> volts, double fpa_K) const noexcept {
    const float dT = static_cast<float>(fpa_K - ambient_K_);
    for (int y = 0; y < volts.height(); ++y)
        applyRow(y, volts.row(y), dT);
}

}  // namespace nvs::bolometer
