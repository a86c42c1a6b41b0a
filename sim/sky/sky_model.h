#pragma once
// The night-sky light at a site, per frame: the Moon above the atmosphere (moon.h), the
// moonless night sky (night_sky.h) and the atmosphere table (atmosphere_table.h) put together.
//
// Horizontal illuminance (or any band: photoelectrons for a camera) at the ground:
//   moon_direct = E_toa,b · T_b(z) · cos z          beam through the slant path
//   moon_sky    = E_toa,b · D_b(z)                   downwelled lunar sky scattering
//   night_sky   = N_b                                airglow, starlight, zodiacal light
// with E_toa,b = ∫E☾(λ) w_b(λ) dλ for the Moon's geometry, z its apparent zenith angle.
// `moon_sky` is the term the thesis's atmosphere builder never computed (its Table 8-3).

#include <filesystem>
#include <string>
#include <vector>

#include "sim/astro/ephemeris.h"
#include "sim/core/paths.h"
#include "sim/sky/atmosphere_table.h"
#include "sim/sky/moon.h"
#include "sim/sky/night_sky.h"

namespace nvs::sky {

struct SkyModelConfig {
    AtmosphereParams atmosphere;
    NightSkyScales nightSky;
    // Bands besides "lux" (683·V(λ)), e.g. a camera's photoelectron band QE(λ)·λ/(hc).
    std::vector<SkyBand> extraBands;
};

struct HorizontalTerms {
    double moonDirect = 0.0;
    double moonSky = 0.0;
    double nightSky = 0.0;
    double total = 0.0;
};

class SkyModel {
  public:
    static constexpr int kLuxBand = 0;

    // Setup: loads the sources from dirs.config and the atmosphere table cached in dirs.cache;
    // throws SetupError.
    static SkyModel create(const SkyModelConfig& config, const DataDirs& dirs,
                           bool* tableRebuilt = nullptr);

    const AtmosphereTable& table() const { return table_; }
    const MoonSource& moon() const { return moon_; }

    // Per frame: no allocation, no throw.
    // The Moon's band irradiance above the atmosphere, normal to its direction.
    double moonToa(int band, const astro::MoonState& moon) const noexcept {
        return table_.sourceBandIntegral(band) * MoonSource::geometryFactor(moon);
    }
    HorizontalTerms horizontal(int band, const astro::MoonState& moon) const noexcept;

  private:
    MoonSource moon_;
    AtmosphereTable table_;
};

// The photoelectron band weight of a camera: QE(λ) [pe/photon] · λ/(h c), so that
// ∫ L_λ w dλ is a photoelectron radiance [pe s⁻¹ m⁻² sr⁻¹].
Spectrum photoelectronWeight(const Spectrum& quantumEfficiency);

}  // namespace nvs::sky
