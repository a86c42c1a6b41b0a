#pragma once
// Down-welling sky radiance in the thermal band against zenith angle (docs/lwir.md §4).
//
// Clear sky: a layered atmosphere from the ground to 40 km, integrated along the slant path
// (spherical shells, no refraction):
//   T(z) = T_air − Γ z up to the tropopause z_t, isothermal above   (US Standard Atmosphere
//          1976, NOAA-S/T 76-1562: Γ = 6.5 K km⁻¹, z_t = 11 km)
//   p(z) = p0 (T/T_air)^(g/(R_d Γ)) below z_t, exponential above (hydrostatic, the same source)
//   ρ_w(z) = ρ_w(0) exp(−z/H_w), H_w = 2 km, capped at saturation (the mid-latitude summer
//          profile of Anderson et al. 1986, AFGL-TR-86-0110, falls by e in ≈ 2 km below 4 km)
//   CO2 well mixed; O3: the surface mixing ratio below z_t plus a Gaussian layer at 22 km,
//          σ 5 km, holding the column (300 DU by default)
//   L(λ, θ) = Σ_k B(λ, T_k) [t(0→z_k) − t(0→z_{k+1})]   (t by Curtis–Godson, absorption.h)
// Clouds: a blackbody at the base, T_c = T_air − Γ z_base, seen through the sub-cloud path;
//   L = (1 − f) L_clear + f [L_sub(θ) + t_sub(θ) B(T_c)], f the cloud fraction.
// Setup-time code (the table, lwir_table.h, is what runs per pixel).

#include "sim/lwir/absorption.h"
#include "sim/lwir/band.h"

namespace nvs::lwir {

struct SkyParams {
    double airTemperature_K = 288.15;
    double vapourPressure_Pa = 1000.0;  // at screen level
    double pressure_Pa = 101325.0;
    double lapseRate_K_m = 0.0065;
    double tropopause_m = 11000.0;
    double waterScaleHeight_m = 2000.0;
    double co2_ppm = 420.0;
    double o3Surface_ppb = 30.0;
    double o3Column_DU = 300.0;
    double cloudFraction = 0.0;  // 0–1
    double cloudBase_m = 1000.0;

    // Throws SetupError on a value out of range.
    void validate() const;
    double cloudTemperature_K() const;
};

// The air of the layered atmosphere at `height_m` above the ground.
AirState airAtHeight(const SkyParams& sky, double height_m);

// τ_band and L_path of a straight line of sight from a sensor `sensorHeight_m` above the ground
// at view zenith θ (0 up, 90° horizontal, 180° down) at each of `ranges_m` (increasing, > 0),
// through the layered atmosphere (flat earth; a line that would go below the ground keeps the
// ground's air). Emission and Curtis–Godson absorption are summed over pieces of at most 50 m
// (plus 10 % of the distance travelled) in height; τ_band is weighted by B(T_air at ground).
std::vector<PathBand> slantPathProfile(const AbsorptionData& data, const BandResponse& band,
                                       const SkyParams& sky, double sensorHeight_m,
                                       double viewZenith_rad, const std::vector<double>& ranges_m);

// Band radiance of the sky at zenith angle θ (0–90°) [W m⁻² sr⁻¹].
double skyBandRadiance_W_m2_sr(const AbsorptionData& data, const BandResponse& band,
                               const SkyParams& sky, double zenith_rad);
// The same at `count` zenith angles from 0 to 90° inclusive, equally spaced (count ≥ 2).
std::vector<double> skyBandRadianceProfile(const AbsorptionData& data, const BandResponse& band,
                                           const SkyParams& sky, int count);
// Band emittance of the sky: its hemispheric down-welling band irradiance over that of a
// blackbody at the air temperature, ∫L cosθ dΩ / (π B_band(T_air)), from a profile as above.
// The sky a plane tilted by β from horizontal (0 faces up, 90° a wall, 180° faces down)
// receives, over π: (1/π) ∫ L(θ) max(0, n·d) dΩ over the sky above the horizon [W m⁻² sr⁻¹],
// from a profile as above (azimuth-independent sky; the ground's part is not included). For a
// uniform sky L₀ it is L₀ (1 + cos β)/2, the sky-view factor.
double tiltedSkyRadiance_W_m2_sr(const std::vector<double>& profile_W_m2_sr, double tilt_rad);
double skyBandEmittance(const BandResponse& band, const SkyParams& sky,
                        const std::vector<double>& profile_W_m2_sr);

}  // namespace nvs::lwir
