// Sun and Moon positions against PyEphem (libastro), an independent ephemeris: 400 instants
// over 1950–2100 at six sites (tests/sim/astro/ephem_reference.csv, written by
// make_ephem_reference.py from Debian's python3-ephem; a ctest re-runs it to check the table).
//
// Both programs are given the same instant in UT1 and the same ΔT (PyEphem's), so that the
// comparison measures the ephemerides and the topocentric reduction, not the ΔT convention for
// future dates (docs/astro.md discusses that separately).

#include "sim/astro/ephemeris.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/core/csv.h"
#include "sim/core/units.h"

namespace nvs::astro {
namespace {

const char* kRefPath = NVS_SOURCE_DIR "/tests/sim/astro/ephem_reference.csv";

// Great-circle separation of two (az, alt) directions [deg].
double separation_deg(double az1_deg, double alt1_deg, double az2_deg, double alt2_deg) {
    const double a1 = az1_deg * kRadPerDeg, h1 = alt1_deg * kRadPerDeg;
    const double a2 = az2_deg * kRadPerDeg, h2 = alt2_deg * kRadPerDeg;
    const double c = std::sin(h1) * std::sin(h2) + std::cos(h1) * std::cos(h2) * std::cos(a1 - a2);
    // Haversine form for small angles.
    const double s = std::sin((h1 - h2) / 2);
    const double t = std::sin((a1 - a2) / 2);
    const double hav = s * s + std::cos(h1) * std::cos(h2) * t * t;
    (void)c;
    return 2.0 * std::asin(std::sqrt(std::min(1.0, hav))) * kDegPerRad;
}

struct Worst {
    double value = 0.0;
    std::string where;
    void update(double v, const std::string& w) {
        if (v > value) {
            value = v;
            where = w;
        }
    }
};

TEST(EphemerisVsPyEphem, PositionsAgreeWithin0p02DegOver1950To2100) {
    const CsvTable ref = CsvTable::load(kRefPath);
    ASSERT_EQ(ref.rowCount(), 400u);
    const auto col = [&](const char* n) { return ref.column(n); };
    Worst sunGeo, moonGeo, sunApp, moonApp, moonDist, phase;
    int refractedRows = 0;
    for (std::size_t r = 0; r < ref.rowCount(); ++r) {
        Site site;
        site.lat_deg = ref.number(r, col("lat_deg"));
        site.lon_deg = ref.number(r, col("lon_deg"));
        site.height_m = ref.number(r, col("height_m"));
        site.pressure_hPa = 0.0;
        const double jd = ref.number(r, col("ut_jd"));
        const AstroTime t =
            astroTimeFromUt1(2400000.5, jd - 2400000.5, ref.number(r, col("delta_t_s")));
        const SunMoonState airless = Ephemeris(site).compute(t);
        site.pressure_hPa = 1010.0;
        site.temperature_C = 10.0;
        const SunMoonState refracted = Ephemeris(site).compute(t);
        const std::string where = ref.rowLoc(r).str();

        sunGeo.update(separation_deg(airless.sun.az_rad * kDegPerRad,
                                     airless.sun.altGeometric_rad * kDegPerRad,
                                     ref.number(r, col("sun_az_deg")),
                                     ref.number(r, col("sun_alt_geometric_deg"))),
                      where);
        moonGeo.update(separation_deg(airless.moon.az_rad * kDegPerRad,
                                      airless.moon.altGeometric_rad * kDegPerRad,
                                      ref.number(r, col("moon_az_deg")),
                                      ref.number(r, col("moon_alt_geometric_deg"))),
                       where);
        // Refracted altitudes: compared where the body is above the horizon. (Below it each
        // program extrapolates its refraction formula differently; nothing is visible there.)
        if (refracted.sun.altGeometric_rad > 0.0) {
            sunApp.update(std::abs(refracted.sun.alt_rad * kDegPerRad -
                                   ref.number(r, col("sun_alt_refracted_deg"))),
                          where);
            ++refractedRows;
        }
        if (refracted.moon.altGeometric_rad > 0.0) {
            moonApp.update(std::abs(refracted.moon.alt_rad * kDegPerRad -
                                    ref.number(r, col("moon_alt_refracted_deg"))),
                           where);
            ++refractedRows;
        }
        // PyEphem's Moon.earth_distance, computed for an Observer, is the topocentric distance.
        moonDist.update(std::abs(airless.moon.distanceTopocentric_m / 1e3 -
                                 ref.number(r, col("moon_distance_km"))),
                        where);
        phase.update(
            std::abs(airless.moon.illuminatedFraction - ref.number(r, col("moon_phase_fraction"))),
            where);
    }
    RecordProperty("sun_geometric_max_deg", std::to_string(sunGeo.value));
    RecordProperty("moon_geometric_max_deg", std::to_string(moonGeo.value));
    std::printf("max separation, airless: Sun %.5f deg (%s), Moon %.5f deg (%s)\n", sunGeo.value,
                sunGeo.where.c_str(), moonGeo.value, moonGeo.where.c_str());
    std::printf(
        "max |alt diff|, refracted (above horizon, %d cases): Sun %.5f deg (%s), "
        "Moon %.5f deg (%s)\n",
        refractedRows, sunApp.value, sunApp.where.c_str(), moonApp.value, moonApp.where.c_str());
    std::printf("max |Moon distance diff| %.1f km, max |illuminated fraction diff| %.5f\n",
                moonDist.value, phase.value);
    EXPECT_LE(sunGeo.value, 0.02) << sunGeo.where;
    EXPECT_LE(moonGeo.value, 0.02) << moonGeo.where;
    EXPECT_LE(sunApp.value, 0.02) << sunApp.where;
    EXPECT_LE(moonApp.value, 0.02) << moonApp.where;
    EXPECT_GT(refractedRows, 300);
    // Distance: both lunar theories are truncated ELP series (tens of km); 0.02° of parallax at
    // the horizon corresponds to ~1% of the distance, so 60 km is a tight check.
    EXPECT_LE(moonDist.value, 60.0) << moonDist.where;
    // libastro derives the fraction from the elongation with Meeus's approximate phase-angle
    // correction; nvstim uses the Sun–Moon–Earth angle itself. They differ by up to ~0.3%.
    EXPECT_LE(phase.value, 0.005) << phase.where;
}

// One context per instant (prepare) for the Sun/Moon and the stars gives the numbers of the
// separate calls, bit for bit, at instants prepared out of order; both give the values this
// code gave before the context was shared (C99 hex floats, printed by that code; to 1e-12 here
// so that another libm's last bit does not fail it).
TEST(Ephemeris, SharedContextGivesTheSeparateCallsNumbers) {
    Site site;
    site.lat_deg = 43.16856;
    site.lon_deg = -77.61583;
    site.height_m = 218.0;
    const Ephemeris eph(site);
    const double ra[3] = {1.7677943, 1.5497299, 4.8735582};
    const double dec[3] = {-0.2917513, 0.1292776, 0.6769031};
    struct Expected {
        const char* utc;
        double sunAz, sunAlt, moonAz, moonAlt, moonPhase, moonDistance_m;
        double starAz[3], starAlt[3];
    };
    const Expected expected[2] = {
        {"1998-09-03T01:00Z",
         0x1.498eea0c86a09p+2,
         -0x1.f505ad80bc1cp-3,
         0x1.68d0a32fe88f3p+1,
         0x1.d0100a6195759p-2,
         0x1.9258c2954991bp-1,
         0x1.67fa316206ce3p+28,
         {0x1.8d874b7f342a7p+2, 0x1.e10dbea94605bp-3, 0x1.95024f9197762p+1},
         {-0x1.1bb24888ad444p+0, -0x1.583546e91c68p-1, 0x1.7e8e7eb206d4p+0}},
        {"2024-01-25T17:54:00Z",
         0x1.a4c33e673fe52p+1,
         0x1.eb4b62611adb7p-2,
         0x1.d22d8b4e25951p-4,
         -0x1.a90355a76014p-2,
         0x1.565c5ba29b126p-4,
         0x1.80d80da03a29ep+28,
         {0x1.02fde1a05d916p+0, 0x1.cf8768866ccb1p-1, 0x1.312c70e1b2f4ep+2},
         {-0x1.c7a1eb2f153ecp-1, -0x1.b22a6bf15b608p-2, 0x1.182663168383cp+0}},
    };
    const AstroTime t0 = astroTimeFromUtc(parseIsoUtc(expected[0].utc, "t0"));
    const AstroTime t1 = astroTimeFromUtc(parseIsoUtc(expected[1].utc, "t1"));
    const AstrometryContext c1 = eph.prepare(t1);  // out of order: no state between calls
    const AstrometryContext c0 = eph.prepare(t0);
    const AstroTime times[2] = {t0, t1};
    const AstrometryContext* contexts[2] = {&c0, &c1};
    for (int i = 0; i < 2; ++i) {
        const Expected& e = expected[i];
        const SunMoonState shared = eph.compute(*contexts[i]);
        const SunMoonState separate = eph.compute(times[i]);
        double azShared[3], altShared[3], azSeparate[3], altSeparate[3];
        eph.stars(*contexts[i], ra, dec, 3, azShared, altShared);
        eph.stars(times[i], ra, dec, 3, azSeparate, altSeparate);
        EXPECT_EQ(shared.sun.az_rad, separate.sun.az_rad) << e.utc;
        EXPECT_EQ(shared.sun.alt_rad, separate.sun.alt_rad) << e.utc;
        EXPECT_EQ(shared.moon.az_rad, separate.moon.az_rad) << e.utc;
        EXPECT_EQ(shared.moon.alt_rad, separate.moon.alt_rad) << e.utc;
        EXPECT_EQ(shared.moon.phaseAngle_rad, separate.moon.phaseAngle_rad) << e.utc;
        EXPECT_EQ(shared.moon.distanceTopocentric_m, separate.moon.distanceTopocentric_m);
        EXPECT_NEAR(shared.sun.az_rad, e.sunAz, 1e-12) << e.utc;
        EXPECT_NEAR(shared.sun.alt_rad, e.sunAlt, 1e-12) << e.utc;
        EXPECT_NEAR(shared.moon.az_rad, e.moonAz, 1e-12) << e.utc;
        EXPECT_NEAR(shared.moon.alt_rad, e.moonAlt, 1e-12) << e.utc;
        EXPECT_NEAR(shared.moon.phaseAngle_rad, e.moonPhase, 1e-12) << e.utc;
        EXPECT_NEAR(shared.moon.distanceTopocentric_m, e.moonDistance_m, 1e-3) << e.utc;
        for (int k = 0; k < 3; ++k) {
            EXPECT_EQ(azShared[k], azSeparate[k]) << e.utc << " star " << k;
            EXPECT_EQ(altShared[k], altSeparate[k]) << e.utc << " star " << k;
            EXPECT_NEAR(azShared[k], e.starAz[k], 1e-12) << e.utc << " star " << k;
            EXPECT_NEAR(altShared[k], e.starAlt[k], 1e-12) << e.utc << " star " << k;
        }
    }
}

}  // namespace
}  // namespace nvs::astro
