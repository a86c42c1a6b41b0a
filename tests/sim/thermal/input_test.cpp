// Bad input stops at set-up with file:line (docs/style.md §8), and the shipped data loads.
#include <gtest/gtest.h>

#include <string>

#include "sim/thermal/heat_balance.h"
#include "sim/thermal/material.h"
#include "sim/thermal/weather.h"

namespace nvs::thermal {
namespace {

const std::string kConfig = std::string(NVS_SOURCE_DIR) + "/config/thermal/";

// The message of the SetupError that `f` throws ("" if none).
template <class F>
std::string setupError(F f) {
    try {
        f();
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

const char* kGoodMaterial = R"(source = "test"
[plate]
source = "test"
emissivity = 0.9
back = "insulated"
[[plate.layer]]
thickness_m = 0.01
conductivity_W_mK = 1.0
density_kg_m3 = 1000.0
specific_heat_J_kgK = 1000.0
)";

std::string replaced(std::string s, const std::string& from, const std::string& to) {
    s.replace(s.find(from), from.size(), to);
    return s;
}

TEST(ThermalInput, GoodMaterialParses) {
    const MaterialLibrary lib = MaterialLibrary::parse(kGoodMaterial, "m.toml");
    EXPECT_TRUE(lib.get("plate", {}).hasThermal());
}

TEST(ThermalInput, EmissivityOutsideZeroOneNamesFileLine) {
    const std::string e =
        setupError([] { MaterialLibrary::parse(replaced(kGoodMaterial, "0.9", "1.2"), "m.toml"); });
    EXPECT_NE(e.find("m.toml:4"), std::string::npos) << e;
    EXPECT_NE(e.find("emissivity"), std::string::npos) << e;
    EXPECT_NE(setupError([] {
                  MaterialLibrary::parse(replaced(kGoodMaterial, "0.9", "-0.1"), "m.toml");
              }).find("m.toml:4"),
              std::string::npos);
}

TEST(ThermalInput, NegativeThicknessNamesFileLine) {
    const std::string e = setupError(
        [] { MaterialLibrary::parse(replaced(kGoodMaterial, "0.01", "-0.01"), "m.toml"); });
    EXPECT_NE(e.find("m.toml:7"), std::string::npos) << e;
    EXPECT_NE(e.find("thickness_m"), std::string::npos) << e;
}

TEST(ThermalInput, UnknownBackAndUnknownKeyNameFileLine) {
    EXPECT_NE(setupError([] {
                  MaterialLibrary::parse(replaced(kGoodMaterial, "\"insulated\"", "\"wall\""),
                                         "m.toml");
              }).find("m.toml:5"),
              std::string::npos);
    // A misspelt key: strict TOML names it with "did you mean".
    const std::string e = setupError([] {
        MaterialLibrary::parse(
            replaced(kGoodMaterial, "emissivity = 0.9", "emissivity = 0.9\nemisivity = 0.9"),
            "m.toml");
    });
    EXPECT_NE(e.find("m.toml:5"), std::string::npos) << e;
}

TEST(ThermalInput, MoreMaterialErrorsNameTheirLine) {
    // A layer without its density: the layer's table is named.
    EXPECT_NE(setupError([] {
                  MaterialLibrary::parse(replaced(kGoodMaterial, "density_kg_m3 = 1000.0\n", ""),
                                         "m.toml");
              }).find("m.toml:6"),
              std::string::npos);
    // A fixed back without its temperature.
    EXPECT_NE(setupError([] {
                  MaterialLibrary::parse(replaced(kGoodMaterial, "\"insulated\"", "\"fixed\""),
                                         "m.toml");
              }).find("back_temperature_K"),
              std::string::npos);
    // A held surface temperature with layers.
    EXPECT_NE(setupError([] {
                  MaterialLibrary::parse(replaced(kGoodMaterial, "emissivity = 0.9",
                                                  "emissivity = 0.9\nsurface_temperature_K = 400"),
                                         "m.toml");
              }).find("m.toml:"),
              std::string::npos);
    // A metal with a dielectric's emissivity, and an unknown angular model.
    EXPECT_NE(setupError([] {
                  MaterialLibrary::parse(replaced(kGoodMaterial, "emissivity = 0.9",
                                                  "emissivity = 0.9\nangular = \"metal\""),
                                         "m.toml");
              }).find("m.toml:2"),
              std::string::npos);
    EXPECT_NE(setupError([] {
                  MaterialLibrary::parse(replaced(kGoodMaterial, "emissivity = 0.9",
                                                  "emissivity = 0.9\nangular = \"mirror\""),
                                         "m.toml");
              }).find("m.toml:5"),
              std::string::npos);
    // A material without a source.
    EXPECT_NE(setupError([] {
                  MaterialLibrary::parse(
                      replaced(kGoodMaterial, "[plate]\nsource = \"test\"\n", "[plate]\n"),
                      "m.toml");
              }).find("source"),
              std::string::npos);
}

TEST(ThermalInput, MaterialWithoutThermalPropertiesNamesBothPlaces) {
    const MaterialLibrary lib = MaterialLibrary::parse(
        "source = \"t\"\n[paint]\nsource = \"t\"\nemissivity = 0.9\n", "m.toml");
    const std::string e = setupError([&] { lib.requireThermal("paint", {"scene.toml", 12, 0}); });
    EXPECT_NE(e.find("scene.toml:12"), std::string::npos) << e;
    EXPECT_NE(e.find("m.toml:2"), std::string::npos) << e;
    EXPECT_NE(e.find("no thermal layers"), std::string::npos) << e;
    EXPECT_NE(setupError([&] {
                  lib.get("chrome", {"scene.toml", 3, 0});
              }).find("scene.toml:3"),
              std::string::npos);
}

const char* kWeather = R"(# source: test
utc,air_temperature_C,dew_point_C,wind_speed_m_s,cloud_fraction,cloud_base_m
1998-09-01T00:00Z,20,12,1.5,0.1,1500
1998-09-01T01:00Z,19,12,1.5,0.1,1500
1998-09-01T03:00Z,18,12,1.5,0.1,1500
)";

TEST(ThermalInput, WeatherTimesAndInterpolation) {
    // POSIX time of 1998-09-02T00:00Z (Python calendar.timegm), with an offset applied.
    EXPECT_EQ(utcSeconds("1998-09-02T00:00Z", "t"), 904694400.0);
    EXPECT_EQ(utcSeconds("1998-09-01T20:00-04:00", "t"), 904694400.0);
    EXPECT_EQ(utcSeconds("2000-03-01T00:00Z", "t") - utcSeconds("2000-02-28T00:00Z", "t"),
              2.0 * 86400.0);  // a leap year
    const WeatherSeries w = WeatherSeries::parse(kWeather, "w.csv");
    const double t0 = utcSeconds("1998-09-01T00:00Z", "t");
    EXPECT_NEAR(w.at(t0 + 1800.0).air_K, 19.5 + kCelsiusZero_K, 1e-9);
    EXPECT_NEAR(w.at(t0 + 2.0 * 3600.0).air_K, 18.5 + kCelsiusZero_K, 1e-9);
    EXPECT_NEAR(w.at(t0 - 1e6).air_K, 20.0 + kCelsiusZero_K, 1e-9);  // clamped
    EXPECT_NEAR(w.at(t0 + 1e6).air_K, 18.0 + kCelsiusZero_K, 1e-9);
}

TEST(ThermalInput, WeatherGapOverThreeHoursNamesFileLine) {
    EXPECT_NO_THROW(WeatherSeries::parse(kWeather, "w.csv"));
    const std::string e =
        setupError([] { WeatherSeries::parse(replaced(kWeather, "T03:00Z", "T04:01Z"), "w.csv"); });
    EXPECT_NE(e.find("w.csv:5"), std::string::npos) << e;
    EXPECT_NE(e.find("gap"), std::string::npos) << e;
}

TEST(ThermalInput, WeatherTimeGoingBackNamesFileLine) {
    const std::string e =
        setupError([] { WeatherSeries::parse(replaced(kWeather, "T03:00Z", "T00:30Z"), "w.csv"); });
    EXPECT_NE(e.find("w.csv:5"), std::string::npos) << e;
}

TEST(ThermalInput, WeatherValuesOutOfRangeNameFileLine) {
    EXPECT_NE(setupError([] {
                  WeatherSeries::parse(replaced(kWeather, "1.5,0.1,1500\n1998-09-01T01",
                                                "1.5,1.5,1500\n1998-09-01T01"),
                                       "w.csv");
              }).find("w.csv:3"),
              std::string::npos);
    // Dew point above the air temperature.
    EXPECT_NE(setupError([] {
                  WeatherSeries::parse(replaced(kWeather, "19,12", "19,25"), "w.csv");
              }).find("w.csv:4"),
              std::string::npos);
    EXPECT_NE(setupError([] {
                  WeatherSeries::parse(replaced(kWeather, "# source: test\n", ""), "w.csv");
              }).find("source"),
              std::string::npos);
}

TEST(ThermalInput, WeatherNotCoveringTheDayBeforeNamesItsFile) {
    const WeatherSeries w = WeatherSeries::parse(kWeather, "w.csv");
    const MaterialLibrary lib = MaterialLibrary::parse(kGoodMaterial, "m.toml");
    SurfaceClass c;
    c.material = lib.get("plate", {});
    const std::string e = setupError([&] {
        solveHeatBalance({c}, w, astro::Site{}, HeatBalanceParams{}, w.end_s(), w.end_s());
    });
    EXPECT_NE(e.find("w.csv"), std::string::npos) << e;
    EXPECT_NE(e.find("24 h"), std::string::npos) << e;
}

TEST(ThermalInput, ShippedMaterialsAndWeatherLoad) {
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    int thermal = 0;
    for (const ThermalMaterial& m : lib.all()) {
        thermal += m.hasThermal() ? 1 : 0;
        EXPECT_GT(m.emissivityHemispherical, 0.0) << m.name;
    }
    EXPECT_GE(thermal, 15);
    for (const char* name : {"grass", "soil_dry", "soil_moist", "asphalt", "concrete",
                             "painted_metal", "glass", "aluminium_polished", "aluminium_bare",
                             "skin", "clothing", "brick", "engine_hood", "exhaust", "lamp_housing"})
        EXPECT_TRUE(lib.requireThermal(name, {}).hasThermal()) << name;
    for (const char* f : {"rochester-1998-08-20.csv", "rochester-1998-08-20-overcast.csv",
                          "rochester-1998-09-02.csv", "rochester-1998-09-06.csv"}) {
        const WeatherSeries w = WeatherSeries::load(kConfig + "weather/" + f);
        EXPECT_GE(w.end_s() - w.start_s(), 48.0 * 3600.0) << f;
        EXPECT_NE(w.source().find("climatology"), std::string::npos) << f;
    }
}

TEST(ThermalInput, WeatherNotANumberOrTooShortNamesFileLine) {
    EXPECT_NE(setupError([] {
                  WeatherSeries::parse(replaced(kWeather, "19,12", "nan,12"), "w.csv");
              }).find("w.csv:4"),
              std::string::npos);
    EXPECT_NE(setupError([] {
                  WeatherSeries::parse(replaced(kWeather, "19,12", "warm,12"), "w.csv");
              }).find("w.csv:4"),
              std::string::npos);
    EXPECT_NE(setupError([] {
                  WeatherSeries::parse(
                      "# source: t\nutc,air_temperature_C,dew_point_C,wind_speed_m_s,"
                      "cloud_fraction,cloud_base_m\n1998-09-01T00:00Z,20,12,1.5,0.1,1500\n",
                      "w.csv");
              }).find("w.csv"),
              std::string::npos);
    EXPECT_NE(setupError([] {
                  WeatherSeries::parse(replaced(kWeather, "1998-09-01T01:00Z", "1998-09-01 1am"),
                                       "w.csv");
              }).find("w.csv:4"),
              std::string::npos);
}

}  // namespace
}  // namespace nvs::thermal
