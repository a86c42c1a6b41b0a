// nvstim illum: illuminance on a horizontal surface at the site from the Moon (direct, through
// the slant path), moonlight scattered by the atmosphere (moon_sky) and the moonless night sky
// (airglow, starlight, zodiacal light), as JSON (docs/design.md §7). With --camera, the same terms
// as photoelectron irradiance in the camera's band, QE(λ)·λ/(hc) weighted.

#include <cmath>
#include <cstdio>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "sim/astro/ephemeris.h"
#include "sim/core/error.h"
#include "sim/core/units.h"
#include "sim/sensor/camera.h"
#include "sim/sky/sky_model.h"
#include "sim/sky/solar.h"

namespace nvs::cli {
namespace {

void printTerms(const char* key, const sky::HorizontalTerms& h) {
    std::printf("\"%s\":{\"moon_direct\":%.6g,\"moon_sky\":%.6g,\"night_sky\":%.6g,\"total\":%.6g}",
                key, h.moonDirect, h.moonSky, h.nightSky, h.total);
}

}  // namespace

int runIllum(const IllumOptions& opts) {
    // Setup.
    astro::Site site;
    site.lat_deg = opts.lat_deg;
    site.lon_deg = opts.lon_deg;
    site.height_m = opts.height_m;
    const astro::Ephemeris eph(site);
    const astro::AstroTime t = astro::astroTimeFromUtc(astro::parseIsoUtc(opts.utc, "--utc"));

    sky::SkyModelConfig config;
    config.atmosphere.siteAltitude_m = opts.height_m;
    if (opts.visibility_km) {
        if (!(*opts.visibility_km > 0.0)) throw SetupError("--visibility-km: must be positive");
        config.atmosphere.visibility_km = *opts.visibility_km;
    }
    const DataDirs dirs = resolveDataDirs();
    std::string cameraName;
    double gain_V = 0.0, luminousGain = 0.0, channelGain = 0.0, perPe = 0.0, qe = 0.0;
    if (!opts.camera && opts.gain_V) throw SetupError("--gain-v: needs --camera");
    if (opts.camera) {
        const sensor::CameraParams cam = sensor::loadCamera(dirs.config, *opts.camera);
        cameraName = cam.name;
        gain_V = opts.gain_V ? *opts.gain_V : cam.gain_V;
        if (!(gain_V >= 0.0)) throw SetupError("--gain-v: must be >= 0");
        luminousGain = cam.luminousGain_fL_fc(gain_V);
        channelGain = cam.mcpChannelGain(gain_V);
        perPe = cam.mcpGain(gain_V);
        qe = cam.qe_peak;
        config.extraBands.push_back(
            {"pe", sky::photoelectronWeight(sensor::cameraResponse(cam) * cam.qe_peak)});
    }
    const sky::SkyModel model = sky::SkyModel::create(config, dirs);
    const Spectrum solar = sky::loadSolarSpectrum_W_m2_nm(dirs.config);
    const Photometry photometry(dirs.config);

    // Evaluation.
    const astro::SunMoonState s = eph.compute(t);
    const sky::HorizontalTerms lux = model.horizontal(sky::SkyModel::kLuxBand, s.moon);

    std::printf("{");
    printTerms("illuminance_lux", lux);
    if (opts.camera) {
        std::printf(",");
        const sky::HorizontalTerms pe = model.horizontal(1, s.moon);
        printTerms("photoelectron_irradiance_pe_s_m2", pe);
        // Photoelectrons per lux of each light: how much more the camera sees of a lux of
        // red-rich night sky than of a lux of moonlight (its response reaches past V(λ)).
        const auto perLux = [](double a, double lx) { return lx > 0.0 ? a / lx : 0.0; };
        const double moon = perLux(pe.moonDirect, lux.moonDirect);
        const double night = perLux(pe.nightSky, lux.nightSky);
        std::printf(
            ",\"pe_per_lux_s_m2\":{\"moon_direct\":%.6g,\"night_sky\":%.6g,"
            "\"night_sky_over_moon\":%.4g}",
            moon, night, moon > 0.0 ? night / moon : 0.0);
        std::printf(",\"camera\":\"%s\"", cameraName.c_str());
        // The tube at the control voltage: screen luminance per cathode illuminance (2856 K), a
        // detected electron's channel gain, and MCP output electrons per photoelectron.
        std::printf(
            ",\"tube\":{\"gain_V\":%.4g,\"luminous_gain_fL_fc\":%.6g,\"mcp_electron_gain\":%.6g,"
            "\"mcp_electrons_per_photoelectron\":%.6g,\"qe_peak\":%.4g}",
            gain_V, luminousGain, channelGain, perPe, qe);
    }
    std::printf(
        ",\"moon\":{\"alt_deg\":%.4f,\"phase_angle_deg\":%.4f,\"illuminated_fraction\":%.5f,"
        "\"toa_normal_lux\":%.6g,\"transmittance\":%.5f}",
        s.moon.alt_rad * kDegPerRad, s.moon.phaseAngle_rad * kDegPerRad, s.moon.illuminatedFraction,
        model.moonToa(sky::SkyModel::kLuxBand, s.moon),
        model.table().directTransmittance(sky::SkyModel::kLuxBand, kPi / 2 - s.moon.alt_rad));
    std::printf(",\"sun\":{\"alt_deg\":%.4f,\"toa_normal_lux\":%.6g}", s.sun.alt_rad * kDegPerRad,
                sky::sunIlluminanceToa_lux(photometry, solar, s.sun.distance_m));
    std::printf(
        ",\"atmosphere\":{\"visibility_km\":%.6g,\"aerosol\":\"%s\",\"site_altitude_m\":%.6g}",
        config.atmosphere.visibility_km, sky::aerosolModelName(config.atmosphere.aerosol),
        config.atmosphere.siteAltitude_m);
    std::printf(",\"notes\":[\"night_sky is the thesis Appendix G moonless sky (0.0012 lx)\"%s]}\n",
                s.sun.alt_rad * kDegPerRad > -18.0
                    ? ",\"the Sun is above -18 deg: twilight and daylight are not in total\""
                    : "");
    return kExitOk;
}

}  // namespace nvs::cli
