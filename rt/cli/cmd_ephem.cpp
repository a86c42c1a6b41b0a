// nvstim ephem: Sun and Moon for a site and UTC instant, as the JSON of docs/design.md §7.

#include <cstdio>

#include "rt/cli/commands.h"
#include "sim/astro/ephemeris.h"
#include "sim/core/units.h"

namespace nvs::cli {

int runEphem(const EphemOptions& opts) {
    // Setup: validate everything before printing anything.
    astro::Site site;
    site.lat_deg = opts.lat_deg;
    site.lon_deg = opts.lon_deg;
    site.height_m = opts.height_m;
    site.pressure_hPa = opts.pressure_hPa;
    site.temperature_C = opts.temperature_C;
    const astro::Ephemeris eph(site);
    const astro::AstroTime t = astro::astroTimeFromUtc(astro::parseIsoUtc(opts.utc, "--utc"));

    const astro::SunMoonState s = eph.compute(t);
    std::printf(
        "{\"sun\":{\"alt_deg\":%.4f,\"alt_geometric_deg\":%.4f,\"az_deg\":%.4f},"
        "\"moon\":{\"alt_deg\":%.4f,\"alt_geometric_deg\":%.4f,\"az_deg\":%.4f,"
        "\"distance_km\":%.1f,\"phase_angle_deg\":%.4f,\"illuminated_fraction\":%.5f}}\n",
        s.sun.alt_rad * kDegPerRad, s.sun.altGeometric_rad * kDegPerRad, s.sun.az_rad * kDegPerRad,
        s.moon.alt_rad * kDegPerRad, s.moon.altGeometric_rad * kDegPerRad,
        s.moon.az_rad * kDegPerRad, s.moon.distanceGeocentric_m / 1e3,
        s.moon.phaseAngle_rad * kDegPerRad, s.moon.illuminatedFraction);
    return kExitOk;
}

}  // namespace nvs::cli
