#pragma once
// Step 2, detector (docs/bolometer.md): the pixel's thermal time constant and responsivity.
//
//   name              unit  default  meaning / source
//   time_constant_s   s     0.010    thermal time constant τ = C/G (typical VOx, preset)
//   responsivity_V_W  V/W   1.0e6    output per absorbed watt (typical; the ADC's counts per
//                                    kelvin fixes the output, so it only scales volts)
//
// A bolometer's temperature obeys C dT/dt + G T = P(t), a first-order lag. With the absorbed
// power held over each frame (Δt = 1/frame rate), the exact discretisation is
//   P̄_k = P_k + (P̄_{k−1} − P_k)·e^(−Δt/τ),
// so a step reaches 1 − e^(−t/τ) of its height at t = kΔt (63 % at t = τ). The detector output
// is V = R·P̄. The first frame starts settled (P̄_0 = P_0: the camera was looking at the scene).

#include "sim/bolometer/stages/stage.h"
#include "sim/core/image.h"

namespace nvs::bolometer {

struct DetectorParams {
    double time_constant_s = 0.010;
    double responsivity_V_W = 1.0e6;

    void read(const Reader& root);
};

class DetectorStage {
  public:
    explicit DetectorStage(const ThermalCameraParams& cam);
    // Advances the lag by one frame with this frame's power and writes the output [V].
    void apply(ImageView<const float> power_W, ImageView<float> volts) noexcept;
    // apply() in rows: beginFrame() once (the retention for this frame: 0 for the first), then
    // applyRow for every row, in any order.
    float beginFrame() noexcept;
    void applyRow(int y, const float* power_W, float* volts, float keep) noexcept;
    // e^(−Δt/τ): the fraction of the last frame's lag state kept.
    double retention() const { return static_cast<double>(keep_); }

  private:
    float keep_;
    float responsivity_;
    bool primed_ = false;
    ImageF lag_W_;
};

}  // namespace nvs::bolometer
