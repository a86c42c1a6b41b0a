#pragma once
// A scenario's thermal set-up, read from its [thermal] table (docs/thermal.md §8):
//
//   [thermal]
//   weather = "weather/rochester-1998-09-02.csv"   # relative to dataDir (config/thermal)
//   materials = "materials.toml"                   # relative to dataDir (this default)
//   linke_turbidity = 3.0
//   dt_s = 60.0
//   [[thermal.surface]]
//   name = "truck roof"
//   material = "painted_metal"
//   tilt_deg = 0.0            # normal from the zenith
//   azimuth_deg = 180.0       # normal from north through east
//   sky_view = 1.0
//   ground_albedo = 0.2
//   deep_temperature_K = 288.2          # optional: replaces a fixed back's temperature
//   sunlit_utc = ["1998-09-01T12:00Z", "1998-09-01T13:00Z"]   # optional shadow history
//   sunlit_fraction = [1.0, 0.0]
//
// Every error names the scenario's file:line: an unknown material, a material without thermal
// layers (with the material's own file:line), angles or fractions out of range, a shadow
// history out of order.

#include <filesystem>
#include <string>
#include <vector>

#include "sim/core/config.h"
#include "sim/thermal/heat_balance.h"

namespace nvs::thermal {

struct ThermalSetup {
    MaterialLibrary materials;
    WeatherSeries weather;
    std::vector<SurfaceClass> classes;
    HeatBalanceParams params;
};

ThermalSetup readThermalSetup(const ConfigTable& thermal, const std::filesystem::path& dataDir);

}  // namespace nvs::thermal
