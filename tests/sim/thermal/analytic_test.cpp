// The solver against the analytic periodic solutions of a semi-infinite solid (Carslaw &
// Jaeger, "Conduction of Heat in Solids", 2nd ed., Oxford 1959, §2.6):
//  1. surface flux q0 cos ωt: T(0, t) = T̄ + q0/(k √(ω/α)) cos(ωt − π/4);
//  2. surface temperature T̄ + ΔT cos ωt: T(z, t) = T̄ + ΔT e^{−z/d} cos(ωt − z/d), d = √(2α/ω).
// Both within 2 % (amplitude; phase within 2 % of π/4 and of z/d).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/core/units.h"
#include "sim/thermal/surface_solver.h"

namespace nvs::thermal {
namespace {

constexpr double kDay_s = 86400.0;
constexpr double kOmega = kTwoPi / kDay_s;

// A thick homogeneous slab (k = 1 W/mK, ρc = 2 MJ/m³K: α = 5e-7 m²/s, d = 0.117 m), 1.5 m deep
// (13 penetration depths), insulated behind: semi-infinite for a daily wave.
ThermalMaterial slab(double thickness_m) {
    ThermalMaterial m;
    m.name = "slab";
    m.emissivityNormal = 0.9;
    m.layers.push_back({thickness_m, 1.0, 2000.0, 1000.0});
    m.back = BackBoundary::Insulated;
    finishMaterial(m);
    return m;
}

// Amplitude and lag (rad) of the first harmonic of samples x_i at t_i = i·dt over one period.
struct Harmonic {
    double amplitude, lag_rad;
};
Harmonic firstHarmonic(const std::vector<double>& x, double dt_s) {
    double a = 0.0, b = 0.0;
    const std::size_t n = x.size();
    for (std::size_t i = 0; i < n; ++i) {
        const double t = static_cast<double>(i) * dt_s;
        a += x[i] * std::cos(kOmega * t);
        b += x[i] * std::sin(kOmega * t);
    }
    a *= 2.0 / static_cast<double>(n);
    b *= 2.0 / static_cast<double>(n);
    return {std::hypot(a, b), std::atan2(b, a)};
}

TEST(HeatBalanceAnalytic, PeriodicSurfaceFluxAmplitudeAndQuarterPiLag) {
    const ThermalMaterial m = slab(1.5);
    const double k = 1.0, alpha = 1.0 / 2.0e6, q0 = 100.0, dt = 60.0;
    SurfaceSolver s(m, Exposure{}, GridParams{}, 290.0);
    const std::size_t perDay = static_cast<std::size_t>(kDay_s / dt);
    std::vector<double> last(perDay);
    for (int day = 0; day < 30; ++day) {
        for (std::size_t i = 0; i < perDay; ++i) {
            // Backward Euler: the flux at the step's end.
            const double t = (static_cast<double>(i) + 1.0) * dt;
            s.stepPrescribedFlux(q0 * std::cos(kOmega * t), 290.0, dt);
            if (day == 29) last[(i + 1) % perDay] = s.surface_K() - 290.0;
        }
    }
    const Harmonic h = firstHarmonic(last, dt);
    const double expected = q0 / (k * std::sqrt(kOmega / alpha));  // 8.29 K
    EXPECT_NEAR(h.amplitude, expected, 0.02 * expected);
    EXPECT_NEAR(h.lag_rad, kPi / 4.0, 0.02 * kPi / 4.0);
    std::printf("flux case: amplitude %.4f K (theory %.4f), lag %.4f rad (theory %.4f)\n",
                h.amplitude, expected, h.lag_rad, kPi / 4.0);
}

TEST(HeatBalanceAnalytic, PeriodicSurfaceTemperaturePenetration) {
    const ThermalMaterial m = slab(1.5);
    const double alpha = 1.0 / 2.0e6, dT = 10.0, dt = 60.0;
    const double d = std::sqrt(2.0 * alpha / kOmega);
    SurfaceSolver s(m, Exposure{}, GridParams{}, 290.0);
    const std::size_t perDay = static_cast<std::size_t>(kDay_s / dt);
    const std::vector<double>& z = s.depths_m();
    // Nodes nearest to d, 2d and 3d.
    std::vector<std::size_t> probe;
    for (double target : {d, 2.0 * d, 3.0 * d}) {
        std::size_t best = 0;
        for (std::size_t i = 0; i < z.size(); ++i)
            if (std::abs(z[i] - target) < std::abs(z[best] - target)) best = i;
        probe.push_back(best);
    }
    std::vector<std::vector<double>> series(probe.size(), std::vector<double>(perDay));
    for (int day = 0; day < 30; ++day) {
        for (std::size_t i = 0; i < perDay; ++i) {
            const double t = (static_cast<double>(i) + 1.0) * dt;
            s.stepPrescribedSurface(290.0 + dT * std::cos(kOmega * t), 290.0, dt);
            if (day == 29)
                for (std::size_t p = 0; p < probe.size(); ++p)
                    series[p][(i + 1) % perDay] = s.temperatures_K()[probe[p]] - 290.0;
        }
    }
    for (std::size_t p = 0; p < probe.size(); ++p) {
        const double zz = z[probe[p]];
        const Harmonic h = firstHarmonic(series[p], dt);
        const double expected = dT * std::exp(-zz / d);
        EXPECT_NEAR(h.amplitude, expected, 0.02 * expected) << "z = " << zz << " m";
        EXPECT_NEAR(h.lag_rad, zz / d, 0.02 * zz / d) << "z = " << zz << " m";
        std::printf("z = %.4f m (%.2f d): amplitude %.4f K (theory %.4f), lag %.4f (theory %.4f)\n",
                    zz, zz / d, h.amplitude, expected, h.lag_rad, zz / d);
    }
}

// Steady conduction through a composite wall (brick 0.1 m, k 0.72, over insulation 0.05 m,
// k 0.04; the face held at 300 K, the back fixed at 280 K): the flux is ΔT/ΣR and the interface
// sits at T_face − ΔT·R_brick/ΣR (series resistances; Incropera et al. §3.1.2).
TEST(HeatBalanceAnalytic, CompositeWallSteadyStateFollowsSeriesResistances) {
    ThermalMaterial m;
    m.name = "wall";
    m.layers.push_back({0.1, 0.72, 1920.0, 835.0});
    m.layers.push_back({0.05, 0.04, 30.0, 1400.0});
    m.back = BackBoundary::FixedTemperature;
    m.backTemperature_K = 280.0;
    finishMaterial(m);
    SurfaceSolver s(m, Exposure{}, GridParams{}, 290.0);
    for (int i = 0; i < 30 * 24; ++i)
        s.stepPrescribedSurface(300.0, 290.0, 3600.0);
    const double r1 = 0.1 / 0.72, r2 = 0.05 / 0.04;
    const double flux = 20.0 / (r1 + r2);
    EXPECT_NEAR(-s.lastFluxes().back_W_m2, flux, 1e-3 * flux);
    const std::vector<double>& z = s.depths_m();
    std::size_t at = 0;
    for (std::size_t i = 0; i < z.size(); ++i)
        if (std::abs(z[i] - 0.1) < std::abs(z[at] - 0.1)) at = i;
    ASSERT_NEAR(z[at], 0.1, 1e-9);  // a node at the interface
    EXPECT_NEAR(s.temperatures_K()[at], 300.0 - 20.0 * r1 / (r1 + r2), 1e-3);
    std::printf("composite wall: back flux %.4f W/m2 (theory %.4f)\n", -s.lastFluxes().back_W_m2,
                flux);
}

// The test can fail: a wrong diffusivity (conductivity doubled) misses theory by far more.
TEST(HeatBalanceAnalytic, AWrongConductivityMissesTheory) {
    ThermalMaterial m = slab(1.5);
    m.layers[0].conductivity_W_mK = 2.0;
    SurfaceSolver s(m, Exposure{}, GridParams{}, 290.0);
    const double dt = 60.0;
    const std::size_t perDay = static_cast<std::size_t>(kDay_s / dt);
    std::vector<double> last(perDay);
    for (int day = 0; day < 10; ++day)
        for (std::size_t i = 0; i < perDay; ++i) {
            const double t = (static_cast<double>(i) + 1.0) * dt;
            s.stepPrescribedFlux(100.0 * std::cos(kOmega * t), 290.0, dt);
            if (day == 9) last[(i + 1) % perDay] = s.surface_K() - 290.0;
        }
    const double theoryForK1 = 100.0 / std::sqrt(kOmega / 5e-7);
    EXPECT_GT(std::abs(firstHarmonic(last, dt).amplitude - theoryForK1), 0.2 * theoryForK1);
}

}  // namespace
}  // namespace nvs::thermal
