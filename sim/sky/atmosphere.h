#pragma once
// Spectral clear-sky atmosphere for night scenes, 350–1100 nm (docs/design.md §4.3).
//
// The column above the site is described by vertical optical depths per wavelength:
//   Rayleigh   τ_R(λ)  Bodhaine et al. (1999) eq. 30, scaled by the site pressure;
//   aerosol    τ_a(λ) = β_a(550)·H_a·(λ/550)^−α, with β_a(550) from the visibility by
//              Koschmieder (3.912/V minus the Rayleigh part), scale height H_a, Ångström α;
//   absorbers  ozone (Chappuis), uniformly mixed gases (O2 A-band) and water vapour, with the
//              coefficients and band-saturation forms of SPECTRL2 (Bird & Riordan 1986,
//              eqs. 2-8, 2-9, 2-11; config/atmosphere/spectrl2_bird_riordan_1986.csv).
// Slant paths use the Kasten & Young (1989) relative airmass, which stays finite and correct
// to within ~0.1 % of a full ray trace at the horizon (it includes refraction).
//
// Downwelled sky radiance from a source (the Moon) is single scattering in a plane-parallel
// column where all constituents share one vertical profile (the optical-depth integral then
// has a closed form), plus a multiple-scattering term: the delta-Eddington two-stream diffuse
// irradiance (Joseph, Wiscombe & Weinman 1976; Meador & Weaver 1980), including the ground's
// reflection, minus the single-scattering irradiance, spread isotropically.
//
// Clouds: a grey, conservatively scattering layer of optical depth τ_c above the clear column.
// It removes exp(−τ_c·m) of the direct beam and passes the Eddington total transmittance
// T_c(μ0) minus that as isotropic diffuse light (which is what the thesis's "cut transmission
// by 75 %" could not do: an overcast Moon still lights the scene, without shadows).
//
// Everything here is setup-phase or table-building code; per-frame lookups go through
// AtmosphereTable (atmosphere_table.h).

#include <filesystem>
#include <string>
#include <string_view>

#include "sim/core/error.h"
#include "sim/core/spectrum.h"

namespace nvs::sky {

enum class AerosolModel { Rural, Urban, Maritime };

// "rural" | "urban" | "maritime"; throws SetupError at `loc` otherwise.
AerosolModel parseAerosolModel(std::string_view name, const FileLoc& loc);
const char* aerosolModelName(AerosolModel m);

// Bulk aerosol optics at 550 nm. Rural from Bird & Riordan (1986) (α = 1.14, ω = 0.945,
// g = 0.65); urban and maritime are the Shettle & Fenn (1979) models' typical values near
// 70–80 % relative humidity.
struct AerosolOptics {
    double angstromExponent;
    double singleScatteringAlbedo;
    double asymmetry;
};
AerosolOptics aerosolOptics(AerosolModel m);

struct AtmosphereParams {
    double siteAltitude_m = 0.0;  // above sea level
    double visibility_km = 23.0;  // meteorological range at 550 nm, at the site
    AerosolModel aerosol = AerosolModel::Rural;
    double aerosolScaleHeight_m = 1200.0;
    double ozone_DU = 300.0;            // column ozone, Dobson units
    double precipitableWater_cm = 1.5;  // at sea level; scaled by exp(−h / 2 km)
    double cloudOpticalDepth = 0.0;     // grey cloud layer above the clear column
    double cloudAsymmetry = 0.85;       // water-cloud droplets
    double groundAlbedo = 0.15;         // for the multiple-scattering term

    // Throws SetupError naming the bad parameter (visibility ≤ 0, negative depths, ...).
    void validate() const;
};

// Relative optical airmass, Kasten & Young (1989): m = 1/(cos z + 0.50572 (96.07995° − z)^−1.6364),
// z the apparent zenith angle. Finite at the horizon (≈ 38); for z ≥ 96° returns 40.
double airmassKastenYoung(double zenith_rad);

// Single-scattering phase functions, normalised to ∫P dΩ = 4π.
// Rayleigh with the King depolarisation of air (ρ_n = 0.0279, Bodhaine et al. 1999):
// P = 3/(4(1+2γ)) · ((1+3γ) + (1−γ) cos²ψ), γ = ρ_n/(2 − ρ_n).
double rayleighPhase(double cosScatter);
// Henyey–Greenstein: P = (1 − g²)/(1 + g² − 2g cos ψ)^{3/2}.
double henyeyGreensteinPhase(double cosScatter, double g);

// Delta-Eddington reflectance and diffuse transmittance of a homogeneous layer for a direct
// beam at cosine μ0 (Meador & Weaver 1980, Eddington γ's, δ-scaling of Joseph et al. 1976).
struct TwoStream {
    double reflectance;           // diffuse reflected / incident (on a horizontal plane)
    double diffuseTransmittance;  // diffuse transmitted / incident
    double directTransmittance;   // exp(−τ/μ0)
};
TwoStream deltaEddington(double tau, double omega, double g, double mu0);
// The layer's spherical albedo, 2∫R(μ)μ dμ (reflectance for isotropic illumination).
double sphericalAlbedo(double tau, double omega, double g);
// The layer's diffuse transmittance for isotropic illumination, 2∫(T_dir + T_dif)(μ)μ dμ.
double diffuseTransmittanceIsotropic(double tau, double omega, double g);

class Atmosphere {
  public:
    // Loads <configDir>/atmosphere/spectrl2_bird_riordan_1986.csv; throws SetupError on bad
    // params.
    Atmosphere(const AtmosphereParams& params, const std::filesystem::path& configDir);

    const AtmosphereParams& params() const { return params_; }
    double sitePressure_hPa() const { return pressure_hPa_; }

    // Vertical optical depths above the site.
    const Spectrum& rayleighTau() const { return tauRayleigh_; }
    const Spectrum& aerosolTau() const { return tauAerosol_; }
    // Absorption optical depth for the homogeneous-mixing scattering model: −ln T_abs(m = 1).
    const Spectrum& absorptionTau() const { return tauAbsorption_; }

    // Beam transmittance from the top of the atmosphere to the site at apparent zenith z,
    // clear column (Rayleigh, aerosol, ozone, mixed gases, water) times the cloud's exp(−τ_c m).
    Spectrum directTransmittance(double zenith_rad) const;

    // Downwelled sky radiance per unit TOA irradiance normal to the source beam [sr⁻¹], at
    // view zenith θv, for a source at zenith θs with cos(scattering angle) = cosScatter:
    // single scattering + isotropic multiple scattering + cloud diffuse.
    void skyRadiancePerIrradiance(double viewZenith_rad, double sourceZenith_rad, double cosScatter,
                                  Spectrum* out) const;
    // Single-scattering part only (exposed for tests).
    void singleScatterRadiancePerIrradiance(double viewZenith_rad, double sourceZenith_rad,
                                            double cosScatter, Spectrum* out) const;

    // Diffuse (sky) irradiance on a horizontal surface per unit TOA normal irradiance,
    // the hemispheric integral of skyRadiancePerIrradiance.
    Spectrum diffuseHorizontalPerIrradiance(double sourceZenith_rad) const;

    // Factor by which the cloud layer passes isotropic light from above (night sky).
    double cloudIsotropicTransmittance() const { return cloudIsotropicT_; }

    // Extinction coefficient at height above the site for path radiance [m⁻¹], per λ:
    // β(h) = τ_R/H_R·e^{−h/H_R} + τ_a/H_a·e^{−h/H_a}.
    void extinctionAtHeight(double height_m, Spectrum* out) const;

    // The direction-independent part of the sky radiance per unit irradiance [sr⁻¹]: the
    // multiple-scattering excess of the two-stream over single scattering, and the cloud's
    // diffuse light seen through the clear column. Costly (a hemispheric integral); the
    // table computes it once per source zenith.
    void isotropicRadiancePerIrradiance(double sourceZenith_rad, Spectrum* out) const;
    // Hemispheric integral of the single-scattering radiance, ∫L_ss cosθ dΩ, per unit
    // irradiance (exposed for tests).
    Spectrum singleScatterHorizontalPerIrradiance(double sourceZenith_rad) const;

  private:
    AtmosphereParams params_;
    AerosolOptics aerosol_;
    double pressure_hPa_ = 1013.25;
    double ozone_atm_cm_ = 0.3;
    double water_cm_ = 1.5;
    Spectrum tauRayleigh_, tauAerosol_, tauAbsorption_;
    Spectrum coefWater_, coefOzone_, coefMixed_;
    double cloudIsotropicT_ = 1.0;
};

}  // namespace nvs::sky
