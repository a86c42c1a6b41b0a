#include "sim/sky/sky_model.h"

#include <cmath>

#include "sim/core/photometry.h"
#include "sim/core/units.h"

namespace nvs::sky {

Spectrum photoelectronWeight(const Spectrum& quantumEfficiency) {
    return Spectrum::fromFunction(
               [](double wl_nm) { return wl_nm * 1e-9 / (kPlanck_J_s * kSpeedOfLight_m_s); }) *
           quantumEfficiency;
}

SkyModel SkyModel::create(const SkyModelConfig& config, const DataDirs& dirs, bool* tableRebuilt) {
    SkyModel m;
    m.moon_ = MoonSource::load(dirs.config);
    const NightSkyModel night = NightSkyModel::load(dirs.config);

    AtmosphereTableInputs in;
    in.atmosphere = config.atmosphere;
    in.sourceShape = m.moon_.referenceIrradiance_W_m2_nm();
    // Airglow (lines, OH and the pseudo-continuum) brightens toward the horizon; starlight and
    // zodiacal light are taken as isotropic.
    NightSkyScales airglow = config.nightSky;
    airglow[NightSkyComponent::Starlight] = 0.0;
    airglow[NightSkyComponent::Zodiacal] = 0.0;
    NightSkyScales continuum{};
    continuum.scale.fill(0.0);
    continuum[NightSkyComponent::Starlight] = config.nightSky[NightSkyComponent::Starlight];
    continuum[NightSkyComponent::Zodiacal] = config.nightSky[NightSkyComponent::Zodiacal];
    night.radiance(airglow, in.nightSky.airglowRadiance_W_m2_sr_nm);
    night.radiance(continuum, in.nightSky.continuumRadiance_W_m2_sr_nm);

    in.bands.push_back({"lux", Photometry(dirs.config).photopicV() * kLuminousEfficacy_lm_W});
    for (const SkyBand& b : config.extraBands)
        in.bands.push_back(b);
    m.table_ = AtmosphereTable::loadOrBuild(in, dirs, tableRebuilt);
    return m;
}

HorizontalTerms SkyModel::horizontal(int band, const astro::MoonState& moon) const noexcept {
    HorizontalTerms h;
    const double zenith_rad = kPi / 2 - moon.alt_rad;
    const double toa = moonToa(band, moon);
    if (moon.alt_rad > 0.0) {
        h.moonDirect = toa * table_.directTransmittance(band, zenith_rad) * std::sin(moon.alt_rad);
    }
    h.moonSky = toa * table_.diffuseHorizontal(band, zenith_rad);
    h.nightSky = table_.nightSkyHorizontal(band);
    h.total = h.moonDirect + h.moonSky + h.nightSky;
    return h;
}

}  // namespace nvs::sky
