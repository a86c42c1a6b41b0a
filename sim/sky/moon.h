#pragma once
// The Moon as a source above the atmosphere (docs/design.md §4.2): spectral irradiance at the
// observer, normal to the Moon's direction.
//
//   E(λ) = E☉(λ) · (1 au / r☉)² · A(λ) · Ω☾/π · Φ(α)
//
//   E☉     solar spectral irradiance at 1 au (solar.h)
//   r☉     Sun–Moon distance
//   Ω☾     solid angle of the lunar disk from the observer, π (R☾/d)², R☾ = 1737.4 km,
//          d the topocentric distance (so moonrise is 1.6 % fainter than transit, as observed)
//   A(λ)   disk-equivalent reflectance at α = 0 without the opposition surge: the spectral
//          shape of Velikodsky et al. (2011, Icarus 214, 30) average lunar albedo, scaled so that
//          at mean distances the photopic illuminance equals that of V = −12.73 mag, the
//          Krisciunas & Schaefer (1991, PASP 103, 1033) full-Moon magnitude
//   Φ(α)   phase law: the Krisciunas & Schaefer magnitude law relative to α = 0,
//          10^(−0.4 (0.026|α| + 4·10⁻⁹ α⁴)), α in degrees, times an opposition surge
//          S(α) = 1 + B exp(−|α|/w), with the e-folding width w = 4.06° of the ROLO model
//          (Kieffer & Stone 2005, AJ 129, 2887, p1) and amplitude B = 0.10 (see docs).
// Phase-dependent reddening (a few % across the band) is not modelled: Φ is grey.

#include <filesystem>

#include "sim/astro/ephemeris.h"
#include "sim/core/spectrum.h"

namespace nvs::sky {

inline constexpr double kMoonRadius_m = 1737.4e3;
inline constexpr double kMoonMeanDistance_m = 384400e3;
inline constexpr double kOppositionSurgeAmplitude = 0.10;
inline constexpr double kOppositionSurgeWidth_deg = 4.06054;

// Krisciunas & Schaefer (1991) eq. 20 in magnitudes: m = −12.73 + 0.026|α| + 4·10⁻⁹ α⁴ (α deg).
double krisciunasSchaeferMagnitude(double phaseAngle_deg);

// Illuminance of a V-magnitude point source above the atmosphere: E = 10^(−0.4 (m + 13.99)) lx
// (V = 0 gives 2.54·10⁻⁶ lx; Allen, Astrophysical Quantities).
double illuminanceFromVMagnitude_lux(double vMagnitude);

// S(α) above.
double oppositionSurge(double phaseAngle_rad);

// Φ(α) above: 1 at α = 0 without the surge, 1 + B with it.
double lunarPhaseLaw(double phaseAngle_rad);

class MoonSource {
  public:
    // Setup: loads the solar spectrum, the albedo shape and V(λ) from configDir, sets the
    // absolute scale.
    static MoonSource load(const std::filesystem::path& configDir);

    // E(λ) at α = 0 (no surge), Sun at 1 au, Moon at mean distance [W m⁻² nm⁻¹].
    const Spectrum& referenceIrradiance_W_m2_nm() const { return reference_; }
    // A(λ) above (dimensionless disk-equivalent reflectance).
    const Spectrum& diskReflectance() const { return reflectance_; }

    // The grey factor that turns the reference into the irradiance for a geometry:
    // Φ(α) · (1 au / r☉)² · (d̄ / d)².
    static double geometryFactor(const astro::MoonState& moon) noexcept;

    // Per frame (no allocation, no throw): illuminance normal to the Moon's direction [lx].
    double illuminanceToa_lux(const astro::MoonState& moon) const noexcept {
        return referenceIlluminance_lux_ * geometryFactor(moon);
    }
    // Per frame: spectral irradiance into `out` [W m⁻² nm⁻¹].
    void spectralIrradianceToa(const astro::MoonState& moon, Spectrum& out) const noexcept;

  private:
    Spectrum reference_;
    Spectrum reflectance_;
    double referenceIlluminance_lux_ = 0.0;
};

}  // namespace nvs::sky
