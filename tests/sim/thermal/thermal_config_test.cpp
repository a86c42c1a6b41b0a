// A scenario's [thermal] table: read, solved, and every bad value named with file:line.
#include "sim/thermal/thermal_config.h"

#include <gtest/gtest.h>

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
    ThermalSetup s = readThermalSetup(doc.root().table("thermal"), kData);
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
    // A weather file with a gap is named with its own file:line.
    EXPECT_NE(setupError([] {
                  read(replaced(kScenario, "rochester-1998-09-02", "nowhere"));
              }).find("nowhere.csv"),
              std::string::npos);
}

}  // namespace
}  // namespace nvs::thermal
