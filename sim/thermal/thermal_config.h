#pragma once
// The [thermal] table (docs/thermal.md §8). A scenario's and a class-set file's share its keys:
//
//   [thermal]
//   weather = "weather/rochester-1998-09-02.csv"   # relative to the file's folder
//   materials = "materials.toml"                   # relative to the file's folder; default
//                                                  # config/thermal/materials.toml
//   linke_turbidity = 3.0                          # readHeatBalanceParams
//   dt_s = 60.0
//
// A scenario adds its camera's lens (focal_length_mm; rt/compose/scenario.cpp) and takes its
// surface classes from its scene; a class-set file (config/thermal/rit-nolight.toml, read by
// readThermalSetup for the heat balance alone) lists them:
//
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

// The heat balance's keys of a [thermal] table: linke_turbidity (1–10, default 3) and dt_s
// (1–3600 s, default 60). Errors name the file:line.
HeatBalanceParams readHeatBalanceParams(const ConfigTable& thermal);

// A class-set file's [thermal] table; dataDir: the file's folder, configThermalDir: config/thermal
// (the default materials file's folder).
ThermalSetup readThermalSetup(const ConfigTable& thermal, const std::filesystem::path& dataDir,
                              const std::filesystem::path& configThermalDir);

}  // namespace nvs::thermal
