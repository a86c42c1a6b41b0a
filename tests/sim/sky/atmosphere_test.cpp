// The atmosphere against laws, analytic limits and independent models.
#include "sim/sky/atmosphere.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/core/photometry.h"
#include "sim/core/planck.h"
#include "sim/core/units.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::sky {
namespace {

// V(λ) from the source tree's config/ (loaded once for this file's tests).
const Photometry& photometry() {
    static const Photometry p(test::configDir());
    return p;
}

int gridIndex(double wavelength_nm) {
    return static_cast<int>(wavelength_nm - SpectralGrid::kMin_nm);
}

// Bodhaine et al. (1999) against the independent fit of Hansen & Travis (1974),
// τ = 0.008569 λ⁻⁴ (1 + 0.0113 λ⁻² + 0.00013 λ⁻⁴), λ in µm, at sea level.
TEST(Atmosphere, RayleighDepthMatchesHansenTravis) {
    AtmosphereParams p;
    const Atmosphere a(p, test::configDir());
    for (double wl : {400.0, 450.0, 550.0, 700.0, 900.0, 1050.0}) {
        const double l = wl * 1e-3;
        const double ht =
            0.008569 * std::pow(l, -4) * (1 + 0.0113 * std::pow(l, -2) + 0.00013 * std::pow(l, -4));
        EXPECT_NEAR(a.rayleighTau()[gridIndex(wl)] / ht, 1.0, 0.01) << wl;
    }
    // Pressure scaling: at 1500 m the column is e^{-1500/8434.5} of sea level.
    p.siteAltitude_m = 1500.0;
    const Atmosphere high(p, test::configDir());
    EXPECT_NEAR(high.rayleighTau()[200] / a.rayleighTau()[200], std::exp(-1500.0 / 8434.5), 1e-9);
}

// Koschmieder: the extinction coefficient at 550 nm at the ground is 3.912 / V.
TEST(Atmosphere, SurfaceExtinctionObeysKoschmieder) {
    for (double vis_km : {2.0, 5.0, 23.0, 100.0}) {
        AtmosphereParams p;
        p.visibility_km = vis_km;
        const Atmosphere a(p, test::configDir());
        Spectrum beta;
        a.extinctionAtHeight(0.0, &beta);
        EXPECT_NEAR(beta[gridIndex(550.0)] * 1e3 * vis_km, 3.912, 1e-6) << vis_km;
    }
}

TEST(Atmosphere, AerosolDepthFollowsAngstromLaw) {
    AtmosphereParams p;
    p.visibility_km = 10.0;
    const Atmosphere a(p, test::configDir());
    const double alpha = aerosolOptics(AerosolModel::Rural).angstromExponent;
    EXPECT_NEAR(a.aerosolTau()[gridIndex(880.0)] / a.aerosolTau()[gridIndex(440.0)],
                std::pow(2.0, -alpha), 1e-9);
}

// Kasten & Young (1989): m(0) ≈ 1, close to sec z at moderate angles, 38.09 at the horizon
// (their Table; a plane-parallel sec z would be infinite).
TEST(Atmosphere, KastenYoungAirmass) {
    EXPECT_NEAR(airmassKastenYoung(0.0), 1.0, 1e-3);
    EXPECT_NEAR(airmassKastenYoung(60.0 * kRadPerDeg), 2.0, 0.01);
    // The formula fits their ray-traced 38.0868 at the horizon to within 0.5 %.
    EXPECT_NEAR(airmassKastenYoung(90.0 * kRadPerDeg), 38.09, 0.19);
    EXPECT_GT(airmassKastenYoung(89.0 * kRadPerDeg), airmassKastenYoung(88.0 * kRadPerDeg));
}

// Phase functions integrate to 4π; Henyey–Greenstein's mean cosine is g.
TEST(Atmosphere, PhaseFunctionsAreNormalised) {
    const int n = 20000;
    double sumR = 0.0, sumHg = 0.0, sumHgCos = 0.0;
    for (int i = 0; i < n; ++i) {
        const double mu = -1.0 + 2.0 * (i + 0.5) / n;
        const double dOmega = 2.0 * kPi * 2.0 / n;
        sumR += rayleighPhase(mu) * dOmega;
        sumHg += henyeyGreensteinPhase(mu, 0.65) * dOmega;
        sumHgCos += henyeyGreensteinPhase(mu, 0.65) * mu * dOmega;
    }
    EXPECT_NEAR(sumR / (4 * kPi), 1.0, 1e-6);
    EXPECT_NEAR(sumHg / (4 * kPi), 1.0, 1e-4);
    EXPECT_NEAR(sumHgCos / (4 * kPi), 0.65, 1e-3);
    // King-corrected Rayleigh: forward/side ratio (1+3γ+1−γ)/(1+3γ) ≈ 1.94, not exactly 2.
    EXPECT_NEAR(rayleighPhase(1.0) / rayleighPhase(0.0), 1.0 + 0.986 / 1.0425, 1e-3);
}

// Delta-Eddington conserves energy when nothing is absorbed, absorbs everything in a thick
// black layer, and reduces to single scattering in a thin one.
TEST(Atmosphere, TwoStreamConservesEnergy) {
    for (double tau : {0.01, 0.3, 1.0, 10.0, 50.0}) {
        for (double mu : {0.1, 0.5, 1.0}) {
            for (double g : {0.0, 0.65, 0.85}) {
                const TwoStream t = deltaEddington(tau, 1.0, g, mu);
                EXPECT_NEAR(t.reflectance + t.diffuseTransmittance + t.directTransmittance, 1.0,
                            1e-4)
                    << tau << " " << mu << " " << g;
            }
        }
    }
    const TwoStream black = deltaEddington(5.0, 0.0, 0.0, 0.7);
    EXPECT_NEAR(black.reflectance, 0.0, 1e-9);
    EXPECT_NEAR(black.diffuseTransmittance, 0.0, 1e-9);
    // Thin isotropic layer: half the scattered beam goes down, R ≈ T_dif ≈ ω τ / (2 μ0).
    const TwoStream thin = deltaEddington(1e-3, 1.0, 0.0, 1.0);
    EXPECT_NEAR(thin.diffuseTransmittance / 5e-4, 1.0, 0.05);
    EXPECT_NEAR(thin.reflectance / 5e-4, 1.0, 0.05);
}

// Single scattering in the thin limit: Rayleigh's phase function is symmetric, so for a
// beam at normal incidence half the scattered light goes down: E_dif → E0 τ_R / 2.
TEST(Atmosphere, SingleScatterThinLimitSendsHalfDown) {
    AtmosphereParams p;
    p.visibility_km = 1e4;  // no aerosol
    p.ozone_DU = 0.0;
    p.precipitableWater_cm = 0.0;
    p.siteAltitude_m = 8000.0;  // thin column: τ_R(1050 nm) ≈ 0.003
    const Atmosphere a(p, test::configDir());
    const int i = gridIndex(1050.0);
    const double tau = a.rayleighTau()[i];
    const double eDown = a.singleScatterHorizontalPerIrradiance(0.0)[i];
    // Exact single scattering for normal incidence: ∫ P/4π·(e^{−τ/μ}−e^{−τ})/(1/μ−1)... ;
    // to first order in τ it is τ/2; the next term, from grazing views, is O(τ ln τ) ≈ 2 %.
    ASSERT_LT(tau, 0.004);
    EXPECT_NEAR(eDown / (tau / 2.0), 1.0, 0.04);
}

// Clear-sky daylight sanity: the diffuse-to-direct ratio on a horizontal surface at 30°
// solar elevation grows with haze and stays in the range measured under clear skies
// (0.1–0.3 at 23 km visibility).
TEST(Atmosphere, DiffuseGrowsWithHaze) {
    const Spectrum& v = photometry().photopicV();
    const Spectrum sun = planckRadiance_W_m2_sr_nm(5772.0);
    double last = 0.0;
    for (double vis : {100.0, 23.0, 5.0}) {
        AtmosphereParams p;
        p.visibility_km = vis;
        const Atmosphere a(p, test::configDir());
        const double z = 45.0 * kRadPerDeg;
        const double dir = integrateProduct_nm(sun * a.directTransmittance(z), v) * std::cos(z);
        const double dif = integrateProduct_nm(sun * a.diffuseHorizontalPerIrradiance(z), v);
        EXPECT_GT(dif / dir, last) << vis;
        if (vis == 23.0) {
            EXPECT_GT(dif / dir, 0.1);
            EXPECT_LT(dif / dir, 0.4);
        }
        last = dif / dir;
    }
}

// A cloud removes the direct beam as exp(−τ_c m) and keeps a large diffuse part.
TEST(Atmosphere, CloudRemovesDirectAddsDiffuse) {
    AtmosphereParams clear;
    AtmosphereParams cloudy;
    cloudy.cloudOpticalDepth = 10.0;
    const Atmosphere a(clear, test::configDir()), c(cloudy, test::configDir());
    const double z = 40.0 * kRadPerDeg;
    const int i = gridIndex(600.0);
    EXPECT_NEAR(c.directTransmittance(z)[i] / a.directTransmittance(z)[i],
                std::exp(-10.0 * airmassKastenYoung(z)), 1e-12);
    const double clearTotal =
        a.directTransmittance(z)[i] * std::cos(z) + a.diffuseHorizontalPerIrradiance(z)[i];
    const double cloudyTotal =
        c.directTransmittance(z)[i] * std::cos(z) + c.diffuseHorizontalPerIrradiance(z)[i];
    // Eddington transmittance of a τ = 10, g = 0.85 cloud is about one half.
    EXPECT_GT(cloudyTotal / clearTotal, 0.3);
    EXPECT_LT(cloudyTotal / clearTotal, 0.7);
    EXPECT_GT(c.diffuseHorizontalPerIrradiance(z)[i], a.diffuseHorizontalPerIrradiance(z)[i]);
}

TEST(Atmosphere, BadParametersAreSetupErrors) {
    AtmosphereParams p;
    p.visibility_km = 0.0;
    EXPECT_THROW((Atmosphere{p, test::configDir()}), SetupError);
    p.visibility_km = -3.0;
    EXPECT_THROW((Atmosphere{p, test::configDir()}), SetupError);
    EXPECT_THROW(parseAerosolModel("desert", FileLoc{"s.toml", 4, 1}), SetupError);
    try {
        parseAerosolModel("desert", FileLoc{"s.toml", 4, 1});
    } catch (const SetupError& e) {
        EXPECT_STREQ(
            e.what(),
            "s.toml:4:1: unknown aerosol model 'desert' (expected rural, urban or maritime)");
    }
}

}  // namespace
}  // namespace nvs::sky
