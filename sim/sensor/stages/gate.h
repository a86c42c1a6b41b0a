#pragma once
// Step 2, gate (docs/sensor.md): how long the photocathode is on in a field.

#include <cstdint>

#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;

struct GateParams {
    // --- 2. Gate -------------------------------------------------------------------------
    double gate_s = 0.0;         // [s] 0 = the whole field
    double gate_min_s = 100e-9;  // [s] fastest gate, 100 ns (Appendix A sec4.3)

    // Reads [gate] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
};

// ---- 2. Gate --------------------------------------------------------------------------------
class GateStage {
  public:
    explicit GateStage(const CameraParams& cam);
    // Exposure for this field: the preset gate, scaled by the auto-gate loop.
    double gate_s(double period_s, double autogateScale) const noexcept;

  private:
    double gate_s_;
    double min_s_;
};

}  // namespace nvs::sensor
