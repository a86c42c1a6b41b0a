#include "sim/thermal/thermal_config.h"

#include "sim/core/units.h"

namespace nvs::thermal {

namespace {

double inRange(const ConfigTable& t, std::string_view key, double def, double lo, double hi) {
    const double v = t.get<double>(key, def);
    if (!(v >= lo && v <= hi))
        t.fail(key, "outside [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    return v;
}

void readShadow(const ConfigTable& s, SurfaceClass& c) {
    const std::vector<std::string> utc = s.get<std::vector<std::string>>("sunlit_utc", {});
    const std::vector<double> f = s.get<std::vector<double>>("sunlit_fraction", {});
    if (utc.size() != f.size()) s.fail("sunlit_fraction", "one fraction per sunlit_utc instant");
    for (std::size_t i = 0; i < utc.size(); ++i) {
        const double t = utcSeconds(utc[i], s.location("sunlit_utc").str() + ": sunlit_utc");
        if (!c.sunlitTimes_s.empty() && !(t > c.sunlitTimes_s.back()))
            s.fail("sunlit_utc", "instants must increase");
        if (!(f[i] >= 0.0 && f[i] <= 1.0)) s.fail("sunlit_fraction", "outside [0, 1]");
        c.sunlitTimes_s.push_back(t);
        c.sunlitFraction.push_back(f[i]);
    }
}

SurfaceClass readSurface(const ConfigTable& s, const MaterialLibrary& lib) {
    SurfaceClass c;
    c.name = s.require<std::string>("name");
    const std::string material = s.require<std::string>("material");
    c.material = lib.requireThermal(material, s.location("material"));
    c.exposure.orientation.tilt_rad = inRange(s, "tilt_deg", 0.0, 0.0, 180.0) * kRadPerDeg;
    c.exposure.orientation.azimuth_rad = inRange(s, "azimuth_deg", 180.0, 0.0, 360.0) * kRadPerDeg;
    c.exposure.skyView = inRange(s, "sky_view", 1.0, 0.0, 1.0);
    c.exposure.groundAlbedo = inRange(s, "ground_albedo", 0.2, 0.0, 1.0);
    if (s.contains("deep_temperature_K"))
        c.exposure.deepTemperature_K = inRange(s, "deep_temperature_K", 0.0, 200.0, 400.0);
    readShadow(s, c);
    return c;
}

}  // namespace

HeatBalanceParams readHeatBalanceParams(const ConfigTable& thermal) {
    HeatBalanceParams p;
    p.forcing.linkeTurbidity = inRange(thermal, "linke_turbidity", 3.0, 1.0, 10.0);
    p.dt_s = inRange(thermal, "dt_s", 60.0, 1.0, 3600.0);
    return p;
}

ThermalSetup readThermalSetup(const ConfigTable& thermal, const std::filesystem::path& dataDir,
                              const std::filesystem::path& configThermalDir) {
    ThermalSetup setup;
    setup.materials = MaterialLibrary::load(
        thermal.contains("materials") ? dataDir / thermal.require<std::string>("materials")
                                      : configThermalDir / "materials.toml");
    setup.weather = WeatherSeries::load(dataDir / thermal.require<std::string>("weather"));
    setup.params = readHeatBalanceParams(thermal);
    for (const ConfigTable& s : thermal.tableArray("surface"))
        setup.classes.push_back(readSurface(s, setup.materials));
    if (setup.classes.empty()) thermal.fail("surface", "a thermal scene needs one surface or more");
    return setup;
}

}  // namespace nvs::thermal
