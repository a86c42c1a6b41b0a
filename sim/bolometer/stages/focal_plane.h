#pragma once
// Step 3, focal plane (docs/bolometer.md): its temperature, and the per-pixel gain and offset
// non-uniformity, the offset drifting with the focal-plane temperature.
//
//   name                     unit  default  meaning / source
//   ambient_K                K     293.15   housing temperature at switch-on
//   self_heating_K           K     4.0      rise from the core's own power, settled (assumed)
//   self_heating_time_s      s     600      its time constant (assumed)
//   drift_K_s                K/s   0        a set drift of the ambient (environment tests)
//   offset_nonuniformity_K   K     2.0      σ of the per-pixel offsets the factory NUC leaves,
//                                           in scene kelvin (assumed; the FFC removes it)
//   gain_nonuniformity_rel   1     0.002    σ of the residual per-pixel gain after the
//                                           factory two-point NUC (assumed)
//   offset_drift_K_per_K     K/K   0.3      σ over pixels of the offset's slope with the
//                                           focal-plane temperature, in scene K per FPA K
//                                           (assumed; its mean is what the camera's
//                                           temperature compensation removes)
//
//   T_fpa(t) = ambient + drift·t + ΔT_self·(1 − e^(−t/τ_self))
//   V_i = g_i·V + o_i + c_i·(T_fpa − ambient),  g_i = 1 + σ_g z, o_i = σ_o z', c_i = σ_c z''
// with z, z', z'' standard normals drawn once per pixel (frame 0 of stream kStreamPattern), each
// map then shifted to mean 1, 0, 0 exactly (what the factory calibration and the camera's
// temperature compensation set),
// and the offsets in volts through the response per scene kelvin at the NETD's reference.

#include <cstdint>

#include "sim/bolometer/stages/stage.h"
#include "sim/core/image.h"

namespace nvs::bolometer {

struct FocalPlaneParams {
    double ambient_K = 293.15;
    double self_heating_K = 4.0;
    double self_heating_time_s = 600.0;
    double drift_K_s = 0.0;
    double offset_nonuniformity_K = 2.0;
    double gain_nonuniformity_rel = 0.002;
    double offset_drift_K_per_K = 0.3;

    void read(const Reader& root);
    double fpaTemperature_K(double t_s) const;
};

class FocalPlaneStage {
  public:
    FocalPlaneStage(const ThermalCameraParams& cam, std::uint64_t seed);
    // V ← g·V + o + c·(T_fpa − ambient), in place.
    void apply(ImageView<float> volts, double fpa_K) const noexcept;
    // One row of it; dT = T_fpa − ambient.
    void applyRow(int y, float* volts, float dT_K) const noexcept;
    // The per-pixel maps [1], [V], [V/K] (for tests).
    const ImageF& gain() const { return gain_; }
    const ImageF& offset_V() const { return offset_V_; }
    const ImageF& drift_V_K() const { return drift_V_K_; }

  private:
    double ambient_K_;
    ImageF gain_, offset_V_, drift_V_K_;
};

}  // namespace nvs::bolometer
