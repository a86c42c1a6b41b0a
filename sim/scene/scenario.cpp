#include "sim/scene/scenario.h"

#include <cmath>

#include "sim/astro/time.h"
#include "sim/core/config.h"

namespace nvs::scene {

namespace {

// Keys of the runtime's minimal scenario format (docs/runtime.md) that the renderer does not
// read: they are checked by rt/run, not here.
constexpr const char* kRuntimeScenarioKeys[] = {"name", "description", "group",     "seed",
                                                "bits", "exposure_s",  "duration_s"};
constexpr const char* kRuntimeTables[] = {"platform", "runtime", "source", "telemetry", "event"};
constexpr const char* kRuntimeCameraKeys[] = {"spectrum", "seed", "controls"};

double finiteIn(const ConfigTable& t, std::string_view key, double fallback, double lo, double hi) {
    const double v = t.get<double>(key, fallback);
    if (!std::isfinite(v) || v < lo || v > hi) {
        t.fail(key, "must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    return v;
}

}  // namespace

RenderScenario loadRenderScenario(const std::filesystem::path& pathIn) {
    std::filesystem::path path = pathIn;
    if (std::filesystem::is_directory(path)) path /= "scenario.toml";
    if (!std::filesystem::exists(path))
        throw SetupError("scenario file not found: " + path.string());
    const ConfigDocument doc = ConfigDocument::parseFile(path);
    const ConfigTable root = doc.root();
    RenderScenario s;
    s.file = path;

    const ConfigTable sc = root.table("scenario");
    s.name = sc.get<std::string>("name", path.stem().string());
    s.utcStart = sc.get<std::string>("utc_start", s.utcStart);
    (void)astro::parseIsoUtc(s.utcStart, sc.location("utc_start").str() + ": utc_start");
    s.frameRate_Hz = finiteIn(sc, "frame_rate_hz", 60.0, 1e-3, 1e4);
    s.width = sc.get<int>("width", 768);
    s.height = sc.get<int>("height", 494);
    if (s.width < 1 || s.width > 8192) sc.fail("width", "must lie in 1..8192");
    if (s.height < 1 || s.height > 8192) sc.fail("height", "must lie in 1..8192");
    for (const char* k : kRuntimeScenarioKeys)
        sc.skip(k);
    for (const char* k : kRuntimeTables)
        root.skip(k);

    const ConfigTable site = root.table("site");
    s.site.lat_deg = finiteIn(site, "lat_deg", 0.0, -90.0, 90.0);
    s.site.lon_deg = finiteIn(site, "lon_deg", 0.0, -180.0, 360.0);
    s.site.height_m = finiteIn(site, "height_m", 0.0, -500.0, 9000.0);
    s.site.pressure_hPa = finiteIn(site, "pressure_hPa", 1013.25, 0.0, 1100.0);
    s.site.temperature_C = finiteIn(site, "temperature_C", 15.0, -80.0, 60.0);
    s.atmosphere.siteAltitude_m = s.site.height_m;

    if (const auto atOpt = root.optionalTable("atmosphere")) {
        const ConfigTable& at = *atOpt;
        s.atmosphere.visibility_km = finiteIn(at, "visibility_km", 23.0, 0.05, 500.0);
        if (at.contains("aerosol")) {
            s.atmosphere.aerosol =
                sky::parseAerosolModel(at.require<std::string>("aerosol"), at.location("aerosol"));
        }
        s.atmosphere.ozone_DU = finiteIn(at, "ozone_DU", 300.0, 0.0, 1000.0);
        s.atmosphere.precipitableWater_cm = finiteIn(at, "precipitable_water_cm", 1.5, 0.0, 10.0);
        s.atmosphere.cloudOpticalDepth = finiteIn(at, "cloud_optical_depth", 0.0, 0.0, 200.0);
        s.atmosphere.groundAlbedo = finiteIn(at, "ground_albedo", 0.15, 0.0, 1.0);
    }

    if (const auto cam = root.optionalTable("camera")) {
        s.cameraPreset = cam->get<std::string>("preset", s.cameraPreset);
        s.cameraOverrides = cam->get<std::vector<std::string>>("set", {});
        for (const char* k : kRuntimeCameraKeys)
            cam->skip(k);
    }

    const ConfigTable scn = root.table("scene");
    const auto rel = scn.require<std::string>("file");
    s.sceneFile = std::filesystem::absolute(path.parent_path() / rel);
    if (!std::filesystem::exists(s.sceneFile)) {
        scn.fail("file", "scene file not found: " + s.sceneFile.string());
    }
    if (scn.contains("lamps_on")) s.lampsOn = scn.require<std::vector<std::string>>("lamps_on");

    doc.finish();
    s.atmosphere.validate();
    return s;
}

}  // namespace nvs::scene
