// The thesis's ephemeris tables (4-1, 4-2, 9-1, 9-2, 10-1; tests/data/thesis) reproduced.
//
// Site (data README): roof of the CIS building, RIT: 43.16856 N, 77.61583 W. The thesis's ephem
// run (Appendix F) used 29.5 inHg (998.9 hPa), 45 °F (7.2 °C) and 800 ft; times are EDT = UTC−4.
//
// Findings checked here (docs/astro.md):
//  * positions agree within 0.1° wherever the body's geometric altitude is above −1°; below
//    that, the old ephem extrapolated its refraction formula under the horizon (+0.4° to +1.3°),
//    a convention for invisible bodies that nvstim does not copy;
//  * the "phase fraction" column is not the illuminated fraction (1+cos i)/2: it is the
//    elongation divided by 180° (a linear phase), which differs by up to 11 points;
//  * Table 10-1: make_adb's altitude is the airless (geometric) topocentric altitude, ephem's is
//    refracted; refraction accounts for every difference above the horizon.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "sim/astro/ephemeris.h"
#include "sim/core/csv.h"
#include "sim/core/units.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::astro {
namespace {

Site thesisSite() {
    Site s;
    s.lat_deg = 43.16856;
    s.lon_deg = -77.61583;
    s.height_m = 800.0 * 0.3048;
    s.pressure_hPa = 29.5 * 33.8639;
    s.temperature_C = (45.0 - 32.0) * 5.0 / 9.0;
    return s;
}

SunMoonState at(const std::string& iso) {
    static const Ephemeris eph(thesisSite());
    return eph.compute(astroTimeFromUtc(parseIsoUtc(iso)));
}

double azDiff_deg(double a, double b) {
    double d = std::fmod(std::abs(a - b), 360.0);
    return d > 180.0 ? 360.0 - d : d;
}

constexpr double kDeg = kDegPerRad;

// Checks one thesis altitude: within 0.1° of nvstim's refracted altitude where the body is up
// (geometric > −1°), else at least the geometric altitude (refraction only raises) and within
// 1.4° of it. Returns the comparison made, for the printed table.
void checkAltitude(const char* what, const std::string& where, double thesis_deg, double alt_deg,
                   double geo_deg, int* visibleChecked) {
    if (geo_deg > -1.0) {
        EXPECT_NEAR(thesis_deg, alt_deg, 0.1) << what << " " << where;
        ++*visibleChecked;
    } else {
        EXPECT_GE(thesis_deg, geo_deg - 0.1) << what << " " << where;
        EXPECT_LE(thesis_deg, geo_deg + 1.4) << what << " " << where;
    }
}

TEST(ThesisTables, Tables4_1And4_2) {
    const CsvTable t =
        CsvTable::load(test::thesisData("table4-1_4-2_ephemeris_collection_nights.csv"));
    int visible = 0;
    double worstLinear = 0.0, worstCos = 0.0;
    std::printf(
        "UTC               | moon az thesis/nvstim | moon alt thesis/nvstim (geo) | "
        "fraction thesis / elong/180 / (1+cos i)/2 | sun alt thesis/nvstim\n");
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        const std::string utc = t.row(r)[t.column("utc_time_iso_derived")];
        const SunMoonState s = at(utc);
        const std::string where = t.rowLoc(r).str();
        const double az = t.number(r, t.column("moon_azimuth_deg"));
        const double alt = t.number(r, t.column("moon_elevation_deg"));
        const double frac = t.number(r, t.column("moon_phase_fraction_pct"));
        const double sunAlt = t.number(r, t.column("sun_zenith_as_labelled_deg"));
        const double linear = s.moon.elongation_rad * kDeg / 180.0 * 100.0;
        const double cosine = s.moon.illuminatedFraction * 100.0;
        std::printf("%s | %6.1f %6.1f | %6.1f %6.2f (%6.2f) | %3.0f %5.1f %5.1f | %6.1f %6.2f\n",
                    utc.c_str(), az, s.moon.az_rad * kDeg, alt, s.moon.alt_rad * kDeg,
                    s.moon.altGeometric_rad * kDeg, frac, linear, cosine, sunAlt,
                    s.sun.alt_rad * kDeg);
        EXPECT_LE(azDiff_deg(az, s.moon.az_rad * kDeg), 0.1) << where;
        checkAltitude("moon", where, alt, s.moon.alt_rad * kDeg, s.moon.altGeometric_rad * kDeg,
                      &visible);
        checkAltitude("sun", where, sunAlt, s.sun.alt_rad * kDeg, s.sun.altGeometric_rad * kDeg,
                      &visible);
        // Printed as whole percent: the linear phase matches to rounding (±0.5 plus the table's
        // own ephemeris error), the illuminated fraction does not.
        worstLinear = std::max(worstLinear, std::abs(frac - linear));
        worstCos = std::max(worstCos, std::abs(frac - cosine));
    }
    std::printf(
        "phase fraction: max |thesis - elongation/180| = %.2f points, "
        "max |thesis - (1+cos i)/2| = %.2f points\n",
        worstLinear, worstCos);
    EXPECT_LE(worstLinear, 0.7);
    EXPECT_GE(worstCos, 8.0);  // the disagreement the tables carry
    EXPECT_GE(visible, 15);
}

TEST(ThesisTables, Tables9_1And9_2) {
    const CsvTable t = CsvTable::load(test::thesisData("table9-1_9-2_sim_conditions.csv"));
    int visible = 0;
    double worstLinear = 0.0, worstCos = 0.0;
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        const std::string utc = t.row(r)[t.column("gmt_iso_derived")];
        const SunMoonState s = at(utc);
        const std::string where = t.rowLoc(r).str();
        const double mAlt = t.number(r, t.column("moon_elevation_deg"));
        const double mAz = t.number(r, t.column("moon_azimuth_deg"));
        const double frac = t.number(r, t.column("moon_fraction_pct"));
        const double sAlt = t.number(r, t.column("sun_elevation_deg"));
        const double sAz = t.number(r, t.column("sun_azimuth_deg"));
        const double linear = s.moon.elongation_rad * kDeg / 180.0 * 100.0;
        const double cosine = s.moon.illuminatedFraction * 100.0;
        std::printf(
            "%s %-9s | moon %6.2f/%6.2f alt, %7.2f/%7.2f az | frac %6.2f lin %6.2f "
            "cos %6.2f | sun %6.2f/%6.2f alt, %7.2f/%7.2f az\n",
            utc.c_str(), t.row(r)[t.column("case")].c_str(), mAlt, s.moon.alt_rad * kDeg, mAz,
            s.moon.az_rad * kDeg, frac, linear, cosine, sAlt, s.sun.alt_rad * kDeg, sAz,
            s.sun.az_rad * kDeg);
        checkAltitude("moon", where, mAlt, s.moon.alt_rad * kDeg, s.moon.altGeometric_rad * kDeg,
                      &visible);
        checkAltitude("sun", where, sAlt, s.sun.alt_rad * kDeg, s.sun.altGeometric_rad * kDeg,
                      &visible);
        EXPECT_LE(azDiff_deg(mAz, s.moon.az_rad * kDeg), 0.1) << where;
        EXPECT_LE(azDiff_deg(sAz, s.sun.az_rad * kDeg), 0.1) << where;
        worstLinear = std::max(worstLinear, std::abs(frac - linear));
        worstCos = std::max(worstCos, std::abs(frac - cosine));
    }
    std::printf(
        "phase fraction: max |thesis - elongation/180| = %.3f points, "
        "max |thesis - (1+cos i)/2| = %.2f points\n",
        worstLinear, worstCos);
    // Printed to 0.01–0.1 %: the linear phase reproduces them to the tables' ephemeris error.
    EXPECT_LE(worstLinear, 0.1);
    EXPECT_GE(worstCos, 8.0);
    EXPECT_GE(visible, 4);
}

// Table 10-1: "ephem" vs "make_adb" altitudes. make_adb = airless, ephem = refracted.
TEST(ThesisTables, Table10_1IsRefraction) {
    const CsvTable t = CsvTable::load(test::thesisData("table10-1_ephem_vs_make_adb.csv"));
    int explained = 0;
    std::printf(
        "local EDT        body | ephem make_adb diff | nvstim alt geo refraction | "
        "residual\n");
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        // Local EDT → UTC: "1998-09-06T08:00-04:00" is parsed with its offset.
        const std::string local = t.row(r)[t.column("time_local_iso_edt_assumed")];
        const SunMoonState s = at(local);
        const std::string where = t.rowLoc(r).str();
        struct Body {
            const char* name;
            double ephem, makeAdb, alt, geo;
        };
        const Body bodies[2] = {{"sun", t.number(r, t.column("sun_alt_ephem_deg")),
                                 t.number(r, t.column("sun_alt_make_adb_deg")),
                                 s.sun.alt_rad * kDeg, s.sun.altGeometric_rad * kDeg},
                                {"moon", t.number(r, t.column("moon_alt_ephem_deg")),
                                 t.number(r, t.column("moon_alt_make_adb_deg")),
                                 s.moon.alt_rad * kDeg, s.moon.altGeometric_rad * kDeg}};
        for (const Body& b : bodies) {
            const double diff = b.ephem - b.makeAdb;
            const double refr = b.alt - b.geo;
            std::printf("%s %-4s | %6.2f %6.2f %5.2f | %6.2f %6.2f %5.2f | %6.2f\n", local.c_str(),
                        b.name, b.ephem, b.makeAdb, diff, b.alt, b.geo, refr, diff - refr);
            // make_adb is the geometric altitude, everywhere (printed to 0.01°).
            EXPECT_NEAR(b.makeAdb, b.geo, 0.03) << b.name << " " << where;
            if (b.geo > -1.0) {
                if (std::string(b.name) == "sun" && std::abs(b.ephem - 16.38) < 1e-9) {
                    // 9/6/98 6 PM: printed 16.38, refracted altitude 16.83 — two digits
                    // transposed in the table; the transposed value fits like every other row.
                    EXPECT_NEAR(16.83, b.alt, 0.03) << where;
                } else if (b.geo > 1.0) {
                    // ephem − make_adb is the refraction nvstim models.
                    EXPECT_NEAR(diff, refr, 0.03) << b.name << " " << where;
                } else {
                    // Within a degree of the horizon refraction models (and the real
                    // atmosphere) differ by a tenth of a degree: 0.69° printed, 0.57° here.
                    EXPECT_NEAR(diff, refr, 0.15) << b.name << " " << where;
                }
                ++explained;
            } else {
                // Below the horizon the old ephem still "refracted" down to a few degrees (its
                // formula extrapolated: +0.37° at −5°, +1.29° at −2°), then stopped; nvstim's
                // convention tapers to 0 at −5°. Either way make_adb is the geometric value.
                EXPECT_GE(diff, -0.03) << b.name << " " << where;
                EXPECT_LE(diff, 1.4) << b.name << " " << where;
            }
        }
    }
    EXPECT_GE(explained, 16);
}

}  // namespace
}  // namespace nvs::astro
