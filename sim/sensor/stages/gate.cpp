#include "sim/sensor/stages/gate.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/sensor/camera.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

void GateParams::read(const PresetReader& root) {
    const PresetReader gate = root.sub("gate");
    gate_s = nonNegative(gate, "gate_s", gate_s);
    gate_min_s = positive(gate, "gate_min_s", gate_min_s);
}

// ---- 2. Gate --------------------------------------------------------------------------------

GateStage::GateStage(const CameraParams& c) : gate_s_(c.gate_s), min_s_(c.gate_min_s) {}

double GateStage::gate_s(double period_s, double autogateScale) const noexcept {
    const double base = (gate_s_ > 0.0 && gate_s_ < period_s) ? gate_s_ : period_s;
    return std::clamp(base * autogateScale, std::min(min_s_, base), base);
}

}  // namespace nvs::sensor
