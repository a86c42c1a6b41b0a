#pragma once
// The render-relevant tables of a scenario file (docs/scene.md "Scenario tables"):
//
//   [scenario]   utc_start, frame_rate_hz, width, height   (the runtime's keys, shared)
//   [site]       lat_deg, lon_deg, height_m, pressure_hPa, temperature_C
//   [atmosphere] visibility_km, aerosol, ozone_DU, precipitable_water_cm,
//                cloud_optical_depth, ground_albedo
//   [camera]     preset, set (KEY=VALUE preset overrides, as the runtime applies them)
//   [scene]      file (relative to the scenario file), lamps_on
//
// The loader is strict: an unknown key in these tables is an error naming file:line. Keys and
// tables that belong to the runtime (docs/runtime.md) are named in `runtimeKeys` and skipped.

#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "sim/astro/ephemeris.h"
#include "sim/sky/atmosphere.h"

namespace nvs::scene {

struct RenderScenario {
    std::filesystem::path file;
    std::string name;
    std::string utcStart = "2000-01-01T00:00:00Z";
    double frameRate_Hz = 60.0;
    int width = 768;
    int height = 494;
    astro::Site site;
    sky::AtmosphereParams atmosphere;
    std::string cameraPreset = "pulnix-ag5745ef3";
    std::vector<std::string> cameraOverrides;         // [camera] set = ["KEY=VALUE", ...]
    std::filesystem::path sceneFile;                  // absolute
    std::optional<std::vector<std::string>> lampsOn;  // absent: each lamp's own `on`

    // Seconds since the scenario epoch of frame k (its start; t_k = k / rate).
    double frameTime_s(long long frame) const { return static_cast<double>(frame) / frameRate_Hz; }
};

// Loads the render tables from a scenario TOML file (or a folder holding scenario.toml).
RenderScenario loadRenderScenario(const std::filesystem::path& path);

}  // namespace nvs::scene
