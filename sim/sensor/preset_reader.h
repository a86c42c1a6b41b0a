#pragma once
// The intensified camera's preset reader: sim/core/preset_reader.h (one reader for every preset).

#include "sim/core/preset_reader.h"
#include "sim/sensor/camera.h"

namespace nvs::sensor {

using nvs::nonNegative;
using nvs::positive;
using nvs::PresetReader;
using nvs::require;

}  // namespace nvs::sensor
