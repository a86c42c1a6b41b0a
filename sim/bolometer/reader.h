#pragma once
// The thermal camera's preset reader (config/thermal_cameras/NAME.toml): the one every preset
// uses, sim/core/preset_reader.h. Each stage's Params reads its own tables through it
// (sim/bolometer/stages/*.h); loadThermalCamera (sim/bolometer/camera.h) runs them in turn.

#include "sim/core/preset_reader.h"

namespace nvs::bolometer {

using Overrides = PresetOverrides;
using Reader = PresetReader;
using nvs::fractionBelow;
using nvs::nonNegative;
using nvs::positive;
using nvs::require;

}  // namespace nvs::bolometer
