// Forcing models against independent models and closed forms: the clear-sky Sun against
// Haurwitz (1945), Brutsaert's clear sky against Swinbank (1963), the overcast sky against
// Crawford & Duchon (1999), Fresnel emissivity against its Brewster-angle closed form and the
// handbook ratios of hemispherical to normal emissivity.
#include "sim/thermal/forcing.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/core/units.h"
#include "sim/thermal/material.h"

namespace nvs::thermal {
namespace {

constexpr double kAu_m = 1.495978707e11;

TEST(ThermalForcing, KastenYoungAirmassIsSecantHighAndFiniteAtHorizon) {
    for (double zDeg : {0.0, 30.0, 60.0})
        EXPECT_NEAR(airmassKastenYoung(zDeg * kRadPerDeg), 1.0 / std::cos(zDeg * kRadPerDeg),
                    0.003 / std::cos(zDeg * kRadPerDeg));
    // Kasten & Young (1989): the exact integral gives 38.09 at 90°, their formula within 0.5 %.
    EXPECT_NEAR(airmassKastenYoung(kPi / 2.0), 38.09, 0.005 * 38.09);
}

// Haurwitz (1945), "Insolation in relation to cloud type", J. Meteorology 3, 123–124:
// GHI = 1098 cos z exp(−0.057/cos z), an independent clear-sky fit (no turbidity input).
TEST(ThermalForcing, IneichenPerezClearSkyAgreesWithHaurwitz) {
    for (double zDeg = 0.0; zDeg <= 70.0; zDeg += 10.0) {
        const double cz = std::cos(zDeg * kRadPerDeg);
        const double haurwitz = 1098.0 * cz * std::exp(-0.057 / cz);
        const SolarIrradiance s = clearSkySolar(zDeg * kRadPerDeg, kAu_m, 150.0, 3.0);
        EXPECT_NEAR(s.ghi_W_m2, haurwitz, 0.10 * haurwitz) << zDeg;
        EXPECT_NEAR(s.ghi_W_m2, s.dni_W_m2 * cz + s.dhi_W_m2, 1e-9);
        EXPECT_GT(s.dhi_W_m2, 0.05 * s.ghi_W_m2);
        EXPECT_LT(s.dhi_W_m2, 0.35 * s.ghi_W_m2);
    }
    EXPECT_EQ(clearSkySolar(95.0 * kRadPerDeg, kAu_m, 150.0, 3.0).ghi_W_m2, 0.0);
}

TEST(ThermalForcing, KastenCzeplakOvercastKeepsAQuarterAllDiffuse) {
    const SolarIrradiance clear = clearSkySolar(0.5, kAu_m, 150.0, 3.0);
    const SolarIrradiance o = cloudySolar(clear, 1.0, std::cos(0.5));
    EXPECT_NEAR(o.ghi_W_m2, 0.25 * clear.ghi_W_m2, 1e-9);
    EXPECT_NEAR(o.dhi_W_m2, o.ghi_W_m2, 1e-9);
    EXPECT_NEAR(o.dni_W_m2, 0.0, 1e-9);
}

// Swinbank (1963), "Long-wave radiation from clear skies", Q. J. R. Meteorol. Soc. 89,
// 339–348: L = 5.31e−13 T⁶ W/m², a fit with no humidity term, good to about ±5 % for
// temperate humid air. Brutsaert for 60–90 % relative humidity at 10–25 °C lies within 8 %.
TEST(ThermalForcing, BrutsaertClearSkyAgreesWithSwinbank) {
    for (double tC : {10.0, 15.0, 20.0, 25.0}) {
        for (double dewDepression : {2.0, 5.0}) {
            WeatherSample w;
            w.air_K = tC + kCelsiusZero_K;
            w.dewPoint_K = w.air_K - dewDepression;
            w.cloudFraction = 0.0;
            const double swinbank = 5.31e-13 * std::pow(w.air_K, 6.0);
            EXPECT_NEAR(longwaveDown_W_m2(w, 0.0065), swinbank, 0.08 * swinbank) << tC;
        }
    }
    // Magnus (Alduchov & Eskridge): 6.1094 hPa at 0 °C, 23.37 hPa at 20 °C (WMO tables 23.39).
    EXPECT_NEAR(vapourPressure_hPa(kCelsiusZero_K), 6.1094, 1e-9);
    EXPECT_NEAR(vapourPressure_hPa(kCelsiusZero_K + 20.0), 23.39, 0.1);
}

// A low overcast radiates nearly as a blackbody at the air temperature: Crawford & Duchon
// (1999) give ε = c + (1 − c) ε_clr = 1 for c = 1; a base at 300 m is within 3 % of it, a high
// base (5 km, colder) well below it.
TEST(ThermalForcing, LowOvercastApproachesCrawfordDuchon) {
    WeatherSample w;
    w.air_K = 288.15;
    w.dewPoint_K = 283.15;
    w.cloudFraction = 1.0;
    w.cloudBase_m = 300.0;
    const double bb = kStefanBoltzmann_W_m2_K4 * std::pow(w.air_K, 4.0);
    EXPECT_NEAR(longwaveDown_W_m2(w, 0.0065), bb, 0.03 * bb);
    w.cloudBase_m = 5000.0;
    EXPECT_LT(longwaveDown_W_m2(w, 0.0065), 0.95 * bb);
    w.cloudFraction = 0.0;
    const double clear = longwaveDown_W_m2(w, 0.0065);
    w.cloudFraction = 0.5;
    w.cloudBase_m = 300.0;
    const double half = longwaveDown_W_m2(w, 0.0065);
    EXPECT_GT(half, clear);
    EXPECT_LT(half, bb);
}

// The grey-slab sky (Granqvist & Hjortsberg 1981): its fitted zenith emissivity reproduces the
// hemispherical one; the slab's closed form at the zenith and the horizon; a wall sees a
// warmer sky than a roof, a blackbody sky is the same for all; a horizontal plane's weight is 1.
TEST(ThermalForcing, AnisotropicSkyOnTiltedPlanes) {
    for (double eff : {0.7, 0.8, 0.9}) {
        const double e0 = slabZenithEmissivity(eff);
        EXPECT_NEAR(slabHemisphericalEmissivity(e0), eff, 1e-6);
        // The closed-form φ integral against a brute-force sum over azimuth (a wall).
        double num = 0.0, den = 0.0;
        for (int i = 0; i < 300; ++i)
            for (int j = 0; j < 600; ++j) {
                const double th = (i + 0.5) * kPi / 600.0, ph = (j + 0.5) * kTwoPi / 600.0;
                const double cg = std::sin(th) * std::cos(ph);
                if (cg <= 0.0) continue;
                num += (1.0 - std::pow(1.0 - e0, 1.0 / std::cos(th))) * cg * std::sin(th);
                den += cg * std::sin(th);
            }
        EXPECT_NEAR(slabMeanEmissivityOnTilt(e0, kPi / 2.0), num / den, 1e-3);
        EXPECT_LT(e0, eff);  // the zenith is the clearest direction
        // Over a horizontal plane the cos-weighted mean is the hemispherical emissivity.
        EXPECT_NEAR(slabMeanEmissivityOnTilt(e0, 0.0), eff, 2e-3);
    }
    const TiltedSky flat(0.0), wall(kPi / 2.0), tilted(kPi / 4.0);
    for (double eff : {0.6, 0.75, 0.85, 0.95}) {
        EXPECT_NEAR(flat.ratio(eff), 1.0, 1e-12);
        EXPECT_GT(wall.ratio(eff), tilted.ratio(eff));
        EXPECT_GT(tilted.ratio(eff), 1.0);
    }
    EXPECT_NEAR(wall.ratio(1.0), 1.0, 1e-4);
    // A clear humid sky (ε_eff 0.8): a wall's sky is about 10 % brighter than a roof's.
    std::printf("wall/roof sky weight at eps_eff 0.8: %.4f, 45 deg: %.4f\n", wall.ratio(0.8),
                tilted.ratio(0.8));
}

TEST(ThermalForcing, ConvectionDoe2Limits) {
    // Calm: natural convection only; stable (cold surface facing up) below unstable.
    const double stable = convectionCoefficient_W_m2K(0.0, 280.0, 288.0, 1.0, 1.0);
    const double unstable = convectionCoefficient_W_m2K(0.0, 296.0, 288.0, 1.0, 1.0);
    EXPECT_NEAR(stable, 1.810 * 2.0 / 2.382, 1e-9);  // |ΔT|^{1/3} = 2
    EXPECT_NEAR(unstable, 9.482 * 2.0 / 6.238, 1e-9);
    EXPECT_NEAR(convectionCoefficient_W_m2K(0.0, 280.0, 288.0, 0.0, 1.0), 1.31 * 2.0, 1e-9);
    // Wind dominates: ASHRAE's smooth-surface 3.26 V^0.89, roughness scales the forced part.
    const double w4 = convectionCoefficient_W_m2K(4.0, 288.0, 288.0, 1.0, 1.0);
    EXPECT_NEAR(w4, 3.26 * std::pow(4.0, 0.89), 1e-9);
    EXPECT_NEAR(convectionCoefficient_W_m2K(4.0, 288.0, 288.0, 1.0, 2.17), 2.17 * w4, 1e-9);
}

TEST(ThermalEmissivity, FresnelAtNormalAndBrewster) {
    const double n = 1.5;
    EXPECT_NEAR(fresnelEmissivity(n, 0.0, 1.0), 1.0 - 0.04, 1e-12);
    // At Brewster's angle R_p = 0 and R_s = ((n² − 1)/(n² + 1))² (Born & Wolf §1.5).
    const double thB = std::atan(n);
    const double rs = std::pow((n * n - 1.0) / (n * n + 1.0), 2.0);
    EXPECT_NEAR(fresnelEmissivity(n, 0.0, std::cos(thB)), 1.0 - 0.5 * rs, 1e-12);
    EXPECT_NEAR(fresnelEmissivity(n, 0.0, 0.0), 0.0, 1e-12);
}

// Hemispherical/normal emissivity: about 0.95–1.0 for non-conductors, 1.0–1.3 for polished
// metals (Incropera et al., Fundamentals of Heat and Mass Transfer, 6th ed., §12.4, Fig. 12.17;
// Siegel & Howell §3.5).
TEST(ThermalEmissivity, HemisphericalOverNormalMatchesHandbookRatios) {
    ThermalMaterial glass;
    glass.emissivityNormal = 0.92;
    glass.angular = AngularModel::Dielectric;
    finishMaterial(glass);
    const double rg = glass.emissivityHemispherical / glass.emissivityNormal;
    EXPECT_GT(rg, 0.93);
    EXPECT_LT(rg, 1.0);
    ThermalMaterial al;
    al.emissivityNormal = 0.05;
    al.angular = AngularModel::Metal;
    finishMaterial(al);
    EXPECT_NEAR(directionalEmissivity(al, 1.0), 0.05, 1e-6);
    const double ra = al.emissivityHemispherical / al.emissivityNormal;
    EXPECT_GT(ra, 1.0);
    EXPECT_LT(ra, 1.35);
    // A metal's emissivity peaks near grazing incidence (above 80°) and is 0 at 90°.
    EXPECT_GT(directionalEmissivity(al, std::cos(85.0 * kRadPerDeg)), 3.0 * 0.05);
    EXPECT_NEAR(directionalEmissivity(al, 0.0), 0.0, 1e-9);
    std::printf("hemispherical/normal: glass %.4f, polished aluminium %.4f\n", rg, ra);
}

}  // namespace
}  // namespace nvs::thermal
