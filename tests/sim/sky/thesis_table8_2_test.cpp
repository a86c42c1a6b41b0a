// The thesis's Table 8-2 night (9/6/98 9 PM – 9/7/98 6 AM EDT, RIT) with the lunar sky term
// its atmosphere builder never computed.
//
// make_adb gave the moonlit rows as direct beam + 0.0012 lx of night sky. Its own daytime rows
// show how much a clear sky scatters: downwelled/direct = 0.24–0.34 for the Sun at 35–51°.
// Moonlight is the same light scattered by the same air, so the lunar sky term should be of
// that size, not the 0.0066 lx (≈ 5 % of direct) the thesis estimated in its Table 8-3.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sim/astro/ephemeris.h"
#include "sim/core/csv.h"
#include "sim/core/units.h"
#include "sim/sky/sky_model.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::sky {
namespace {

std::filesystem::path thesisData(const char* f) {
    return std::filesystem::path(NVS_TEST_DATA_DIR) / "thesis" / f;
}

TEST(ThesisTable8_2, NightRowsWithLunarSkyScattering) {
    const CsvTable t = CsvTable::load(thesisData("table8-2_illuminance_timeline_make_adb.csv"));
    const auto cTime = t.column("time_local_iso_edt_assumed");
    const auto cMoonAlt = t.column("moon_elevation_deg");
    const auto cDirect = t.column("moon_direct_with_trans_lux");
    const auto cDown = t.column("downwelled_lux");
    const auto cSun = t.column("sun_elevation_deg");
    const auto cSunDirect = t.column("sun_direct_with_trans_lux");

    // make_adb's daytime downwelled/direct ratios for the Sun between 30° and 55°.
    double dayLo = 1e9, dayHi = 0.0;
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        const double sunEl = t.number(r, cSun);
        if (sunEl >= 30.0 && sunEl <= 55.0) {
            const double ratio = t.number(r, cDown) / t.number(r, cSunDirect);
            dayLo = std::min(dayLo, ratio);
            dayHi = std::max(dayHi, ratio);
        }
    }
    ASSERT_GT(dayHi, 0.0);

    astro::Site site;
    site.lat_deg = 43.16856;
    site.lon_deg = -77.61583;
    site.height_m = 218.0;
    const astro::Ephemeris eph(site);
    SkyModelConfig c;
    c.atmosphere.siteAltitude_m = 218.0;
    c.atmosphere.visibility_km = 23.0;  // thesis §9.1: clear sky, 23 km
    const SkyModel model = SkyModel::create(
        c,
        DataDirs{test::configDir(), std::filesystem::temp_directory_path() / "nvs_table8_2_test"});

    std::printf("%-22s %6s %9s %9s %9s %9s %9s\n", "EDT", "alt", "adb_dir", "dir", "sky", "adb_tot",
                "total");
    int high = 0;
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        const std::string& iso = t.row(r)[cTime];
        if (t.empty(r, cMoonAlt) || t.number(r, cSun) > -5.0 || t.number(r, cMoonAlt) <= 0.0)
            continue;
        const astro::SunMoonState s = eph.compute(astro::astroTimeFromUtc(astro::parseIsoUtc(iso)));
        const HorizontalTerms h = model.horizontal(SkyModel::kLuxBand, s.moon);
        const double adbDirect = t.number(r, cDirect);
        const double adbTotal = adbDirect + t.number(r, cDown);
        std::printf("%-22s %6.1f %9.4f %9.4f %9.4f %9.4f %9.4f\n", iso.c_str(),
                    s.moon.alt_rad * kDegPerRad, adbDirect, h.moonDirect, h.moonSky, adbTotal,
                    h.total);
        // The moonless part is the same 0.0012 lx.
        EXPECT_NEAR(h.nightSky, 0.0012, 0.0001);
        if (s.moon.alt_rad * kDegPerRad >= 30.0) {
            ++high;
            // High Moon: the direct beams agree (the extinction along short paths matches).
            EXPECT_NEAR(h.moonDirect / adbDirect, 1.0, 0.2) << iso;
            // The lunar sky term has the size make_adb's own daytime sky has.
            EXPECT_GT(h.moonSky / h.moonDirect, 0.8 * dayLo) << iso;
            EXPECT_LT(h.moonSky / h.moonDirect, 1.3 * dayHi) << iso;
            // And far more than the thesis's 0.0066 lx estimate.
            EXPECT_GT(h.moonSky, 3.0 * 0.0066) << iso;
            EXPECT_GT(h.total, 1.2 * adbTotal) << iso;
        }
    }
    EXPECT_EQ(high, 3);  // 12 AM, 2 AM, 4 AM
}

}  // namespace
}  // namespace nvs::sky
