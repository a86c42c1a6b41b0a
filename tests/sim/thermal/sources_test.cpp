// Heat sources and shadows against hand-computed steady balances: at night, with the weather
// changing by about 1 K an hour, a thin panel is in quasi-steady state (its time constant,
// ρc·thickness over its loss coefficient, is minutes), so its temperature solves
//   q_in + ε_h L_in = ε_h σT⁴ + h_c(T)(T − T_a)
// for the heat q_in reaching its face — solved here by bisection, not by the solver.
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

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

struct Fixture {
    MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    WeatherSeries w = WeatherSeries::load(kConfig + "weather/rochester-1998-09-02.csv");
    double t = utcSeconds("1998-09-02T05:00Z", "test");

    SurfaceClass horizontal(const char* material) const {
        SurfaceClass c;
        c.name = material;
        c.material = lib.requireThermal(material, {});
        return c;
    }
};

// Root of f on [lo, hi] by bisection (f(lo) > 0 > f(hi)).
double bisect(const std::function<double(double)>& f, double lo, double hi) {
    for (int i = 0; i < 100; ++i) {
        const double mid = 0.5 * (lo + hi);
        (f(mid) > 0.0 ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

// The steady face temperature of a horizontal panel under the night sky at t with heat
// `conductance·(Tback − T) + flux` arriving from behind.
double steadyNight(const ThermalMaterial& m, const WeatherSample& ws, double conductance,
                   double back_K, double flux) {
    const double L = longwaveDown_W_m2(ws, 0.0065);
    const double eps = m.emissivityHemispherical;
    auto net = [&](double T) {
        const double h =
            convectionCoefficient_W_m2K(ws.wind_m_s, T, ws.air_K, 1.0, m.roughnessMultiplier);
        return conductance * (back_K - T) + flux + eps * L -
               eps * kStefanBoltzmann_W_m2_K4 * std::pow(T, 4.0) - h * (T - ws.air_K);
    };
    return bisect(net, 200.0, 500.0);
}

TEST(HeatBalanceSources, ExhaustHeldAtItsTemperature) {
    const Fixture f;
    EXPECT_NEAR(
        surfaceTemperature_K(f.horizontal("exhaust"), f.w, rochester(), HeatBalanceParams{}, f.t),
        393.15, 1e-3);
}

// A housing heated from inside: `flux_W_m2` from behind, insulated; its heat balance against the
// steady hand balance, and at least `above_K` over the air.
void expectHeatedHousing(const char* material, double flux_W_m2, double above_K) {
    const Fixture f;
    const SurfaceClass c = f.horizontal(material);
    const double solved = surfaceTemperature_K(c, f.w, rochester(), HeatBalanceParams{}, f.t);
    const double hand = steadyNight(c.material, f.w.at(f.t), 0.0, 0.0, flux_W_m2);
    EXPECT_NEAR(solved, hand, 0.5) << material;
    EXPECT_GT(solved, f.w.at(f.t).air_K + above_K) << material;
    std::printf("%s: solved %.2f K, steady hand balance %.2f K, air %.2f K\n", material, solved,
                hand, f.w.at(f.t).air_K);
}

TEST(HeatBalanceSources, LampHousingMatchesItsSteadyBalance) {
    expectHeatedHousing("lamp_housing", 150.0, 5.0);
}

// The thesis's street lamp lit (scenarios/thesis-stlamp-lwir): its 40 W through the steel box's
// walls, 107 W/m².
TEST(HeatBalanceSources, LitLampBoxMatchesItsSteadyBalance) {
    expectHeatedHousing("lamp_box_40w", 107.0, 3.0);
}

TEST(HeatBalanceSources, EngineHoodMatchesItsSteadyBalance) {
    const Fixture f;
    const SurfaceClass c = f.horizontal("engine_hood");
    const double solved = surfaceTemperature_K(c, f.w, rochester(), HeatBalanceParams{}, f.t);
    // Series conductance of the bay air and the steel to the 70 °C bay.
    double r = 0.0;
    for (const Layer& l : c.material.layers)
        r += l.thickness_m / l.conductivity_W_mK;
    const double hand = steadyNight(c.material, f.w.at(f.t), 1.0 / r, 343.15, 0.0);
    EXPECT_NEAR(solved, hand, 0.5);
    std::printf("engine hood: solved %.2f K, steady hand balance %.2f K\n", solved, hand);
}

TEST(HeatBalanceSources, ShadedConcreteIsCoolerInTheAfternoon) {
    const Fixture f;
    SurfaceClass sun = f.horizontal("concrete");
    SurfaceClass shade = sun;
    // Shaded from 13:00 to 23:00 UTC on both days (the history is clamped outside its range).
    const double d0 = utcSeconds("1998-08-31T00:00Z", "test");
    for (double day : {0.0, 1.0}) {
        for (double hour : {12.9, 13.0, 23.0, 23.1}) {
            shade.sunlitTimes_s.push_back(d0 + day * 86400.0 + hour * 3600.0);
            shade.sunlitFraction.push_back(hour == 12.9 || hour == 23.1 ? 1.0 : 0.0);
        }
    }
    const double at = utcSeconds("1998-09-01T19:00Z", "test");  // 15:00 EDT
    const SurfaceTemperatureTable t =
        solveHeatBalance({sun, shade}, f.w, rochester(), HeatBalanceParams{}, at, at);
    EXPECT_GT(t.at(0, at), t.at(1, at) + 5.0);
    EXPECT_NEAR(sunlitAt(shade, d0 + 18.0 * 3600.0), 0.0, 1e-12);
    EXPECT_NEAR(sunlitAt(shade, d0 + 12.95 * 3600.0), 0.5, 1e-9);
    std::printf("concrete at 15:00 EDT: sunlit %.2f K, shaded %.2f K, air %.2f K\n", t.at(0, at),
                t.at(1, at), f.w.at(at).air_K);
}

// A panel facing the ground (a vehicle's underside: tilt 180°, no sky) stays near the air at
// night: it sees only surroundings at the air temperature.
TEST(HeatBalanceSources, AnUndersideStaysNearTheAir) {
    const Fixture f;
    SurfaceClass c = f.horizontal("painted_metal");
    c.exposure.orientation.tilt_rad = kPi;
    c.exposure.skyView = 0.0;
    const double T = surfaceTemperature_K(c, f.w, rochester(), HeatBalanceParams{}, f.t);
    EXPECT_NEAR(T, f.w.at(f.t).air_K, 1.0);
}

// The table covers the requested range even off the step grid, and reads between samples
// linearly.
TEST(HeatBalanceSources, TableCoversItsRangeOffTheGrid) {
    const Fixture f;
    const double start = f.t - 90.0, end = f.t + 30.0;  // 05:00Z is on the 60-s grid
    const SurfaceTemperatureTable t = solveHeatBalance(
        {f.horizontal("painted_metal")}, f.w, rochester(), HeatBalanceParams{}, start, end);
    EXPECT_LE(t.t0_s(), start);
    EXPECT_GE(t.t0_s() + t.dt_s() * static_cast<double>(t.samples() - 1), end);
    const double mid = t.t0_s() + 0.25 * t.dt_s();
    const double expected =
        0.75 * static_cast<double>(t.sample(0, 0)) + 0.25 * static_cast<double>(t.sample(0, 1));
    EXPECT_NEAR(t.at(0, mid), expected, 1e-9);
}

// The night-cooling ranges can fail: a roof that sees no sky (sky-view 0) does not cool.
TEST(HeatBalanceSources, ARoofWithoutSkyDoesNotCool) {
    const Fixture f;
    SurfaceClass c = f.horizontal("painted_metal");
    c.exposure.skyView = 0.0;
    const double T = surfaceTemperature_K(c, f.w, rochester(), HeatBalanceParams{}, f.t);
    EXPECT_LT(f.w.at(f.t).air_K - T, 1.0);
}

}  // namespace
}  // namespace nvs::thermal
