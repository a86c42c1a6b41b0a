// Writes the data behind docs/atmosphere.md's plots as CSV (docs/plots/atmosphere.sh runs it
// and gnuplot):
//   sky_vs_rho.csv       moonlit sky luminance along the Moon's vertical, several
//                        visibilities, with the Krisciunas & Schaefer (1991) model
//   night_timeline.csv   horizontal illuminance terms through the night of 6–7 Sep 1998 at RIT
// Usage: nvs_report_atmosphere OUT_DIR

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "sim/astro/ephemeris.h"
#include "sim/core/units.h"
#include "sim/sky/sky_model.h"
#include "tests/sim/core/test_paths.h"

using namespace nvs;

int main(int argc, char** argv) {
    if (argc != 2) {
        std::fprintf(stderr, "usage: %s OUT_DIR\n", argv[0]);
        return 2;
    }
    const std::string out = argv[1];
    const double visibilities[] = {100.0, 23.0, 5.0};
    sky::SkyModel models[3] = {sky::SkyModel(), sky::SkyModel(), sky::SkyModel()};
    for (int i = 0; i < 3; ++i) {
        sky::SkyModelConfig c;
        c.atmosphere.siteAltitude_m = 218.0;
        c.atmosphere.visibility_km = visibilities[i];
        models[i] = sky::SkyModel::create(c, nvs::test::dataDirs());
    }

    // 1. Sky luminance along the vertical through a Moon at 40° altitude, phase 10°, by
    //    elevation angle: 0–90° on the Moon's side, 90–180° past the zenith.
    {
        FILE* f = std::fopen((out + "/sky_vs_rho.csv").c_str(), "w");
        if (f == nullptr) return 1;
        astro::MoonState moon;
        moon.alt_rad = 40.0 * kRadPerDeg;
        moon.phaseAngle_rad = 10.0 * kRadPerDeg;
        moon.distanceTopocentric_m = sky::kMoonMeanDistance_m;
        moon.sunDistance_m = 1.496e11;
        const double zm = kPi / 2 - moon.alt_rad;
        std::fprintf(f, "elevation_deg,L_100km_cd_m2,L_23km_cd_m2,L_5km_cd_m2,L_ks_100km_cd_m2\n");
        const double mag = -12.73 + 0.026 * 10.0 + 4e-9 * 1e4;
        const double istar = std::pow(10.0, -0.4 * (mag + 16.57));
        const double k = -2.5 * std::log10(models[0].table().directTransmittance(0, 0.0));
        const auto ksX = [](double z) {
            return 1.0 / std::sqrt(1.0 - 0.96 * std::pow(std::sin(z), 2));
        };
        // Walk from the horizon below the Moon, through the zenith, to the opposite horizon.
        for (double el = 1.0; el <= 179.0; el += 1.0) {
            const double z = std::fabs(90.0 - el) * kRadPerDeg;
            const double dphi = el < 90.0 ? 0.0 : kPi;
            const double cosRho =
                std::cos(z) * std::cos(zm) + std::sin(z) * std::sin(zm) * std::cos(dphi);
            const double rho = std::acos(std::clamp(cosRho, -1.0, 1.0)) * kDegPerRad;
            std::fprintf(f, "%.2f", el);
            for (int i = 0; i < 3; ++i) {
                std::fprintf(f, ",%.6g",
                             models[i].moonToa(0, moon) /
                                 sky::oppositionSurge(moon.phaseAngle_rad) *
                                 models[i].table().skyRadiance(0, z, dphi, zm));
            }
            const double f_rho =
                std::pow(10.0, 5.36) * (1.06 + cosRho * cosRho) + std::pow(10.0, 6.15 - rho / 40.0);
            const double bnl = f_rho * istar * std::pow(10.0, -0.4 * k * ksX(zm)) *
                               (1.0 - std::pow(10.0, -0.4 * k * ksX(z)));
            std::fprintf(f, ",%.6g\n", rho >= 10.0 ? bnl * 1e-9 * 1e4 / kPi : std::nan(""));
        }
        std::fclose(f);
    }

    // 2. Illuminance through the night of 6–7 Sep 1998 at RIT, every 10 minutes.
    {
        FILE* f = std::fopen((out + "/night_timeline.csv").c_str(), "w");
        if (f == nullptr) return 1;
        astro::Site site;
        site.lat_deg = 43.16856;
        site.lon_deg = -77.61583;
        site.height_m = 218.0;
        const astro::Ephemeris eph(site);
        const astro::AstroTime t0 =
            astro::astroTimeFromUtc(astro::parseIsoUtc("1998-09-07T00:00Z"));
        std::fprintf(f,
                     "hours_after_2000_edt,moon_alt_deg,direct_23km_lx,sky_23km_lx,night_lx,"
                     "total_23km_lx,total_100km_lx,total_5km_lx,sky_5km_lx\n");
        for (int m = 0; m <= 11 * 60; m += 10) {
            const astro::SunMoonState s = eph.compute(t0.plusSeconds(m * 60.0));
            const sky::HorizontalTerms h23 = models[1].horizontal(0, s.moon);
            const sky::HorizontalTerms h100 = models[0].horizontal(0, s.moon);
            const sky::HorizontalTerms h5 = models[2].horizontal(0, s.moon);
            std::fprintf(f, "%.4f,%.3f,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g,%.6g\n", m / 60.0,
                         s.moon.alt_rad * kDegPerRad, h23.moonDirect, h23.moonSky, h23.nightSky,
                         h23.total, h100.total, h5.total, h5.moonSky);
        }
        std::fclose(f);
    }
    return 0;
}
