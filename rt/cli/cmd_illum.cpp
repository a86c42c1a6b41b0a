// nvstim illum: illuminance on a horizontal surface from the Moon and the night sky (DESIGN §7).
//
// This stage gives the terms above the atmosphere: moon_direct is the lunar illuminance without
// extinction, times sin(apparent altitude); moon_sky (moonlight scattered by the atmosphere) is
// 0 until the atmosphere model exists; night_sky is the thesis's measured moonless sky
// (Appendix G, a ground measurement). The "notes" key says so in the output.

#include <cmath>
#include <cstdio>

#include "rt/cli/commands.h"
#include "sim/astro/ephemeris.h"
#include "sim/core/error.h"
#include "sim/core/units.h"
#include "sim/sky/moon.h"
#include "sim/sky/night_sky.h"
#include "sim/sky/solar.h"

namespace nvs::cli {

int runIllum(const IllumOptions& opts) {
    // Setup.
    if (opts.camera)
        throw SetupError(
            "--camera: photoelectron irradiance needs camera presets, which this "
            "build does not have yet");
    astro::Site site;
    site.lat_deg = opts.lat_deg;
    site.lon_deg = opts.lon_deg;
    site.height_m = opts.height_m;
    const astro::Ephemeris eph(site);
    const astro::AstroTime t = astro::astroTimeFromUtc(astro::parseIsoUtc(opts.utc, "--utc"));
    const sky::MoonSource moon = sky::MoonSource::load();
    const sky::NightSkyModel nightSky = sky::NightSkyModel::load();
    const Spectrum solar = sky::loadSolarSpectrum_W_m2_nm();

    // Evaluation.
    const astro::SunMoonState s = eph.compute(t);
    const double moonNormal_lux = moon.illuminanceToa_lux(s.moon);
    const double moonDirect_lux =
        s.moon.alt_rad > 0.0 ? moonNormal_lux * std::sin(s.moon.alt_rad) : 0.0;
    const double moonSky_lux = 0.0;
    const double nightSky_lux = nightSky.horizontalIlluminance_lux(sky::NightSkyScales{});
    const double sunNormal_lux = sky::sunIlluminanceToa_lux(solar, s.sun.distance_m);
    const double total_lux = moonDirect_lux + moonSky_lux + nightSky_lux;

    std::printf(
        "{\"illuminance_lux\":{\"moon_direct\":%.6g,\"moon_sky\":%.6g,\"night_sky\":%.6g,"
        "\"total\":%.6g},",
        moonDirect_lux, moonSky_lux, nightSky_lux, total_lux);
    std::printf(
        "\"moon\":{\"alt_deg\":%.4f,\"phase_angle_deg\":%.4f,\"illuminated_fraction\":%.5f,"
        "\"toa_normal_lux\":%.6g},",
        s.moon.alt_rad * kDegPerRad, s.moon.phaseAngle_rad * kDegPerRad, s.moon.illuminatedFraction,
        moonNormal_lux);
    std::printf("\"sun\":{\"alt_deg\":%.4f,\"toa_normal_lux\":%.6g},", s.sun.alt_rad * kDegPerRad,
                sunNormal_lux);
    std::printf(
        "\"notes\":[\"top of atmosphere: moon_direct has no atmospheric extinction\","
        "\"moon_sky is 0 until the atmosphere model (lunar sky scattering) is added\","
        "\"night_sky is the thesis Appendix G moonless sky (0.0012 lx)\"%s%s]}\n",
        opts.visibility_km ? ",\"--visibility-km is not used until the atmosphere model "
                             "is added\""
                           : "",
        s.sun.alt_rad * kDegPerRad > -18.0
            ? ",\"the Sun is above -18 deg: twilight and daylight are not in total\""
            : "");
    return kExitOk;
}

}  // namespace nvs::cli
