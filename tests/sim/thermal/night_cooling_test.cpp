// Night cooling in early-September Rochester weather (config/thermal/weather, climatology of
// the thesis nights), clear sky and light wind, solved through the whole pipeline (forcing
// series, spin-up, table):
//  - horizontal grass and a vehicle roof end below the air temperature by amounts inside
//    measured ranges:
//      grass: grass-minimum thermometers read below the screen almost every night, by as much
//        as 10 K on clear calm nights (Brugge 2011, "Contrasts between air and grass minimum
//        temperatures", Weather 66, doi:10.1002/wea.760); ground frost with the screen at
//        4–5 °C (WeatherOnline Europe, "Grass minimum temperature"): 1–10 K;
//      car roof: horizontal car panels cool radiatively below the air on clear nights and form
//        dew while the vertical windows and sides stay warmer (Beysens et al. 2022, "A study to
//        explore the dew condensation potential of cars", Atmosphere 13(1), 65,
//        doi:10.3390/atmos13010065); dew condensers cool a few kelvin below the air, up to
//        about 8 K (Beysens 1995, "The formation of dew", Atmospheric Research 39, 215–237):
//        1–8 K;
//  - an overcast sky (cloud fraction 1, base 300 m) cuts each deficit by more than half;
//  - the roof (horizontal, sky view 1) is colder than the sides (vertical, sky view 0.5), as the
//    thesis (Appendix M) observed of the vehicle and aircraft tops.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>

#include "sim/core/units.h"
#include "sim/thermal/heat_balance.h"

namespace nvs::thermal {
namespace {

const std::string kConfig = std::string(NVS_SOURCE_DIR) + "/config/thermal/";

astro::Site rochester() {
    astro::Site s;
    s.lat_deg = 43.16856;
    s.lon_deg = -77.61583;
    s.height_m = 150.0;
    return s;
}

SurfaceClass surface(const MaterialLibrary& lib, const char* material, double tilt_deg,
                     double skyView) {
    SurfaceClass c;
    c.name = material;
    c.material = lib.requireThermal(material, {});
    c.exposure.orientation.tilt_rad = tilt_deg * kRadPerDeg;
    c.exposure.orientation.azimuth_rad = kPi;
    c.exposure.skyView = skyView;
    return c;
}

WeatherSeries overcast(const WeatherSeries& w) {
    std::vector<WeatherSample> s = w.samples();
    for (WeatherSample& x : s) {
        x.cloudFraction = 1.0;
        x.cloudBase_m = 300.0;
    }
    return WeatherSeries::fromSamples(w.times_s(), s, "overcast variant");
}

struct Night {
    double grass_K, roof_K, side_K, air_K;
    std::vector<double> dew_kg_m2;
};

Night solve(const WeatherSeries& w) {
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    const std::vector<SurfaceClass> classes = {surface(lib, "grass", 0.0, 1.0),
                                               surface(lib, "painted_metal", 0.0, 1.0),
                                               surface(lib, "painted_metal", 90.0, 0.5)};
    // 02:00 EDT, 1998-09-02: the thesis nights' hours.
    const double t = utcSeconds("1998-09-02T06:00Z", "test");
    HeatBalanceReport rep;
    const SurfaceTemperatureTable table =
        solveHeatBalance(classes, w, rochester(), HeatBalanceParams{}, t - 3600.0, t, {}, &rep);
    for (int d : rep.spinupDays)
        EXPECT_LT(d, 60);
    std::printf("spin-up days: grass %d, roof %d, side %d; unconverged steps %llu\n",
                rep.spinupDays[0], rep.spinupDays[1], rep.spinupDays[2],
                static_cast<unsigned long long>(rep.unconvergedSteps));
    EXPECT_EQ(rep.unconvergedSteps, 0u);
    return {table.at(0, t), table.at(1, t), table.at(2, t), w.at(t).air_K, rep.dew_kg_m2};
}

TEST(HeatBalanceNight, ClearLightWindGrassAndRoofBelowAirInMeasuredRanges) {
    const WeatherSeries w = WeatherSeries::load(kConfig + "weather/rochester-1998-09-02.csv");
    const double t = utcSeconds("1998-09-02T06:00Z", "test");
    ASSERT_GE(w.at(t).wind_m_s, 1.0);
    ASSERT_LE(w.at(t).wind_m_s, 2.0);
    const Night clear = solve(w);
    const double grass = clear.air_K - clear.grass_K, roof = clear.air_K - clear.roof_K,
                 side = clear.air_K - clear.side_K;
    std::printf("clear: air %.2f K; grass %.2f K below, roof %.2f K below, side %.2f K below\n",
                clear.air_K, grass, roof, side);
    EXPECT_GE(grass, 1.0);
    EXPECT_LE(grass, 10.0);
    EXPECT_GE(roof, 1.0);
    EXPECT_LE(roof, 8.0);
    // Appendix M: the roof, open to the whole sky, is colder than the sides.
    EXPECT_LT(clear.roof_K, clear.side_K - 0.5);
    // Beysens et al. (2022): dew forms on the rooftop first, the lateral surfaces later or not.
    EXPECT_GT(clear.dew_kg_m2[1], 0.0);
    EXPECT_GT(clear.dew_kg_m2[1], clear.dew_kg_m2[2]);
    std::printf("dew held at 06:00 UTC: grass %.4f, roof %.4f, side %.4f kg/m2\n",
                clear.dew_kg_m2[0], clear.dew_kg_m2[1], clear.dew_kg_m2[2]);

    const Night cloudy = solve(overcast(w));
    const double grassO = cloudy.air_K - cloudy.grass_K, roofO = cloudy.air_K - cloudy.roof_K;
    std::printf("overcast: grass %.2f K below, roof %.2f K below (clear %.2f, %.2f)\n", grassO,
                roofO, grass, roof);
    EXPECT_LT(grassO, 0.5 * grass);
    EXPECT_LT(roofO, 0.5 * roof);
}

// Wind mixes the air's heat down: the clear-night deficit shrinks as the night wind grows (the
// "clear and calm" condition of every radiation-frost forecast; Brugge 2011).
TEST(HeatBalanceNight, DeficitShrinksWithWind) {
    const WeatherSeries w = WeatherSeries::load(kConfig + "weather/rochester-1998-09-02.csv");
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    const double t = utcSeconds("1998-09-02T06:00Z", "test");
    double previous = 1e9;
    for (double night_m_s : {0.5, 1.5, 3.0, 6.0}) {
        std::vector<WeatherSample> s = w.samples();
        for (WeatherSample& x : s)
            if (x.wind_m_s < 2.0) x.wind_m_s = night_m_s;
        const WeatherSeries windy = WeatherSeries::fromSamples(w.times_s(), s, "wind variant");
        const double T = surfaceTemperature_K(surface(lib, "painted_metal", 0.0, 1.0), windy,
                                              rochester(), HeatBalanceParams{}, t);
        const double deficit = windy.at(t).air_K - T;
        std::printf("night wind %.1f m/s: roof %.2f K below air\n", night_m_s, deficit);
        EXPECT_LT(deficit, previous);
        previous = deficit;
    }
}

// The shipped overcast night (1998-08-20, the overcast-starlight scenario): no deficit to speak
// of, against about 3–4 K on the clear file of the same date.
TEST(HeatBalanceNight, ShippedOvercastNightBarelyCools) {
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    const std::vector<SurfaceClass> classes = {surface(lib, "grass", 0.0, 1.0),
                                               surface(lib, "painted_metal", 0.0, 1.0)};
    const double t = utcSeconds("1998-08-20T04:00Z", "test");
    double deficit[2][2];
    int k = 0;
    for (const char* f : {"rochester-1998-08-20.csv", "rochester-1998-08-20-overcast.csv"}) {
        const WeatherSeries w = WeatherSeries::load(kConfig + "weather/" + f);
        const SurfaceTemperatureTable table =
            solveHeatBalance(classes, w, rochester(), HeatBalanceParams{}, t, t);
        for (int c = 0; c < 2; ++c)
            deficit[k][c] = w.at(t).air_K - table.at(c, t);
        ++k;
    }
    for (int c = 0; c < 2; ++c) {
        EXPECT_GT(deficit[0][c], 1.0);
        EXPECT_LT(deficit[1][c], 0.5 * deficit[0][c]);
    }
    std::printf("1998-08-20 04:00Z: clear grass %.2f, roof %.2f K below; overcast %.2f, %.2f\n",
                deficit[0][0], deficit[0][1], deficit[1][0], deficit[1][1]);
}

TEST(HeatBalanceNight, CacheReturnsTheSameTableAndAPolishedFiducialIsColdest) {
    const WeatherSeries w = WeatherSeries::load(kConfig + "weather/rochester-1998-09-02.csv");
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    const std::vector<SurfaceClass> classes = {surface(lib, "grass", 0.0, 1.0),
                                               surface(lib, "aluminium_polished", 0.0, 1.0),
                                               surface(lib, "skin", 90.0, 0.5)};
    const double t = utcSeconds("1998-09-02T04:00Z", "test");
    const std::filesystem::path dir = std::filesystem::path(NVS_BINARY_DIR) / "test-thermal-cache";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir);
    HeatBalanceReport a, b;
    const SurfaceTemperatureTable t1 =
        solveHeatBalance(classes, w, rochester(), HeatBalanceParams{}, t - 600.0, t, dir, &a);
    const SurfaceTemperatureTable t2 =
        solveHeatBalance(classes, w, rochester(), HeatBalanceParams{}, t - 600.0, t, dir, &b);
    EXPECT_FALSE(a.fromCache);
    EXPECT_TRUE(b.fromCache);
    EXPECT_TRUE(std::filesystem::exists(a.cacheFile));
    EXPECT_EQ(t1.data(), t2.data());
    // A damaged cache file is not trusted: solved again and rewritten.
    std::filesystem::resize_file(a.cacheFile, 40);
    HeatBalanceReport c;
    const SurfaceTemperatureTable t3 =
        solveHeatBalance(classes, w, rochester(), HeatBalanceParams{}, t - 600.0, t, dir, &c);
    EXPECT_FALSE(c.fromCache);
    EXPECT_EQ(t3.data(), t1.data());
    EXPECT_GT(std::filesystem::file_size(a.cacheFile), 40u);
    // Another input, another key.
    std::vector<SurfaceClass> other = classes;
    other[0].exposure.skyView = 0.9;
    EXPECT_NE(heatBalanceKey(other, w, rochester(), HeatBalanceParams{}, t - 600.0, t),
              heatBalanceKey(classes, w, rochester(), HeatBalanceParams{}, t - 600.0, t));
    // A cache folder that does not exist is a set-up error naming it.
    try {
        solveHeatBalance(classes, w, rochester(), HeatBalanceParams{}, t - 600.0, t,
                         dir / "missing");
        ADD_FAILURE() << "no error";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("missing"), std::string::npos);
    }
    // The fiducial (ε 0.05) loses almost nothing by radiation: its true temperature stays near
    // the air, but it emits 5 % of a blackbody: its radiance is far below the grass's.
    const double air = w.at(t).air_K;
    EXPECT_NEAR(t1.at(1, t), air, 1.5);
    const double grassExitance = 0.98 * std::pow(t1.at(0, t), 4.0);
    const double alExitance = 0.05 * std::pow(t1.at(1, t), 4.0);
    EXPECT_LT(alExitance, 0.1 * grassExitance);
    // Skin over a 37 °C core sits between the air and the core.
    EXPECT_GT(t1.at(2, t), air + 5.0);
    EXPECT_LT(t1.at(2, t), 310.15);
    std::printf("at %s: air %.2f, grass %.2f, polished Al %.2f, skin %.2f K; state %zu bytes\n",
                "1998-09-02T04:00Z", air, t1.at(0, t), t1.at(1, t), t1.at(2, t), a.stateBytes);
}

TEST(HeatBalanceNight, StateOfManyClassesStaysFarBelow256MB) {
    const WeatherSeries w = WeatherSeries::load(kConfig + "weather/rochester-1998-09-02.csv");
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    std::vector<SurfaceClass> classes;
    for (int i = 0; i < 16; ++i)
        classes.push_back(surface(lib, "painted_metal", 5.0 * i, 1.0 - i / 32.0));
    const double t = utcSeconds("1998-09-02T06:00Z", "test");
    HeatBalanceReport rep;
    const auto start = std::chrono::steady_clock::now();
    const SurfaceTemperatureTable table = solveHeatBalance(
        classes, w, rochester(), HeatBalanceParams{}, t - 5.0 * 3600.0, t, {}, &rep);
    const double seconds =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    std::printf("16 classes solved in %.2f s (forcing series and spin-up included)\n", seconds);
    // Per class: the solver (nodes and work arrays) and its table row; shared: the forcing.
    EXPECT_LT(rep.stateBytes, 256u << 20);
    std::printf("16 classes, 5 h table: state %zu bytes, table %zu bytes\n", rep.stateBytes,
                table.bytes());
}

}  // namespace
}  // namespace nvs::thermal
