// A scenario's [thermal] table: read, solved, and every bad value named with file:line.
#include "sim/thermal/thermal_config.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

namespace nvs::thermal {
namespace {

const std::filesystem::path kData = std::filesystem::path(NVS_SOURCE_DIR) / "config/thermal";

const char* kScenario = R"([thermal]
weather = "weather/rochester-1998-09-02.csv"
[[thermal.surface]]
name = "truck roof"
material = "painted_metal"
tilt_deg = 0.0
sky_view = 1.0
[[thermal.surface]]
name = "truck side"
material = "painted_metal"
tilt_deg = 90.0
azimuth_deg = 90.0
sky_view = 0.5
sunlit_utc = ["1998-09-01T12:00Z", "1998-09-01T16:00Z"]
sunlit_fraction = [1.0, 0.0]
)";

ThermalSetup read(const std::string& text) {
    const ConfigDocument doc = ConfigDocument::parseString(text, "scn.toml");
    ThermalSetup s = readThermalSetup(doc.root().table("thermal"), kData, kData);
    doc.finish();
    return s;
}

template <class F>
std::string setupError(F f) {
    try {
        f();
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

std::string replaced(std::string s, const std::string& from, const std::string& to) {
    s.replace(s.find(from), from.size(), to);
    return s;
}

TEST(ThermalConfig, ReadsAndSolvesAScenarioTable) {
    const ThermalSetup s = read(kScenario);
    ASSERT_EQ(s.classes.size(), 2u);
    EXPECT_EQ(s.classes[1].sunlitFraction.size(), 2u);
    const double t = utcSeconds("1998-09-02T04:00Z", "t");
    astro::Site site;
    site.lat_deg = 43.16856;
    site.lon_deg = -77.61583;
    const SurfaceTemperatureTable table =
        solveHeatBalance(s.classes, s.weather, site, s.params, t, t);
    EXPECT_LT(table.at(0, t), table.at(1, t));  // the roof colder than the side
}

TEST(ThermalConfig, MaterialWithoutThermalLayersNamesTheScenarioLine) {
    const std::string e =
        setupError([] { read(replaced(kScenario, "\"painted_metal\"", "\"sky_backdrop\"")); });
    EXPECT_NE(e.find("scn.toml:5"), std::string::npos) << e;
    EXPECT_NE(e.find("materials.toml:"), std::string::npos) << e;
    EXPECT_EQ(e.find('\n'), std::string::npos) << e;  // one line
    EXPECT_NE(setupError([] {
                  read(replaced(kScenario, "\"painted_metal\"", "\"chrome\""));
              }).find("scn.toml:5"),
              std::string::npos);
}

TEST(ThermalConfig, BadValuesNameTheirLine) {
    EXPECT_NE(setupError([] {
                  read(replaced(kScenario, "sky_view = 0.5", "sky_view = 1.5"));
              }).find("scn.toml:13"),
              std::string::npos);
    EXPECT_NE(setupError([] {
                  read(replaced(kScenario, "\"1998-09-01T16:00Z\"", "\"1998-09-01T11:00Z\""));
              }).find("scn.toml:14"),
              std::string::npos);
    EXPECT_NE(
        setupError([] { read(replaced(kScenario, "[1.0, 0.0]", "[1.0]")); }).find("scn.toml:15"),
        std::string::npos);
    // A misspelt key: strict TOML names it, with the nearest valid key.
    const std::string misspelt =
        setupError([] { read(replaced(kScenario, "sky_view = 1.0", "skyview = 1.0")); });
    EXPECT_NE(misspelt.find("scn.toml:7"), std::string::npos) << misspelt;
    EXPECT_NE(misspelt.find("sky_view"), std::string::npos) << misspelt;
    // A weather file that is not there is named.
    EXPECT_NE(setupError([] {
                  read(replaced(kScenario, "rochester-1998-09-02", "nowhere"));
              }).find("nowhere.csv"),
              std::string::npos);
}

// The shipped example for the RIT nolight night (config/thermal/rit-nolight.toml), solved at
// the scenario's instant: the person warmest, the truck's roof colder than its side, the
// polished fiducial's exitance far below everything else's (the thesis's reason to use it, §4),
// every surface within the night's physical bounds (sky-cooled below the air, the body's core).
TEST(ThermalConfig, RitNolightExampleOrdersAsPhysicsSays) {
    const ConfigDocument doc = ConfigDocument::parseFile(kData / "rit-nolight.toml");
    const ThermalSetup s = readThermalSetup(doc.root().table("thermal"), kData, kData);
    doc.finish();
    astro::Site site;
    site.lat_deg = 43.16856;
    site.lon_deg = -77.61583;
    site.height_m = 218.0;
    const double t = utcSeconds("1998-09-02T01:00Z", "t");
    const SurfaceTemperatureTable table =
        solveHeatBalance(s.classes, s.weather, site, s.params, t, t);
    auto temp = [&](const char* name) {
        for (std::size_t k = 0; k < s.classes.size(); ++k)
            if (s.classes[k].name == name) return table.at(k, t);
        ADD_FAILURE() << name;
        return 0.0;
    };
    const double air = s.weather.at(t).air_K;
    std::printf("RIT nolight 01:00Z, air %.2f K:\n", air);
    double minExitanceOthers = 1e30;
    for (std::size_t k = 0; k < s.classes.size(); ++k) {
        const double T = table.at(k, t);
        const double exitance = s.classes[k].material.emissivityHemispherical * std::pow(T, 4.0);
        std::printf("  %-16s %.2f K (%+.2f), exitance/sigma %.3g\n", s.classes[k].name.c_str(), T,
                    T - air, exitance);
        EXPECT_GT(T, air - 10.0) << s.classes[k].name;
        EXPECT_LT(T, 310.15) << s.classes[k].name;
        if (s.classes[k].name != "fiducial")
            minExitanceOthers = std::min(minExitanceOthers, exitance);
    }
    EXPECT_GT(temp("person face"), temp("person clothes"));
    EXPECT_GT(temp("person clothes"), air);
    EXPECT_LT(temp("truck roof"), temp("truck side"));
    EXPECT_LT(temp("grass"), air);
    const double al = 0.05 * std::pow(temp("fiducial"), 4.0);
    EXPECT_LT(al, 0.2 * minExitanceOthers);
}

}  // namespace
}  // namespace nvs::thermal
