#pragma once
// Planck's law for a blackbody at temperature T.
//
//   L_λ(λ, T) = 2 h c² / λ⁵ · 1 / (exp(h c / (λ k T)) − 1)      [W m⁻² sr⁻¹ m⁻¹]
//   M_λ = π L_λ (Lambertian exitance),  I_λ = L_λ · A_proj (intensity of an area A_proj)
//
// A tungsten filament is a cylinder of radius r and length h. Averaged over directions, a
// convex body's projected area is a quarter of its surface (Cauchy's formula), so a coil seen
// from an arbitrary direction has A_proj = 2π r h / 4 = π r h / 2.

#include "sim/core/spectrum.h"

namespace nvs {

double planckSpectralRadiance_W_m2_sr_m(double wavelength_m, double temperature_K);

inline double planckSpectralRadiance_W_m2_sr_nm(double wavelength_nm, double temperature_K) {
    return planckSpectralRadiance_W_m2_sr_m(wavelength_nm * 1e-9, temperature_K) * 1e-9;
}
double planckSpectralExitance_W_m2_nm(double wavelength_nm, double temperature_K);
double planckSpectralIntensity_W_sr_nm(double wavelength_nm, double temperature_K,
                                       double projectedArea_m2);
// Spectral photon radiance, L_λ · λ / (h c)  [photons s⁻¹ m⁻² sr⁻¹ nm⁻¹].
double planckSpectralPhotonRadiance_nm(double wavelength_nm, double temperature_K);

// The radiance curve on the grid [W m⁻² sr⁻¹ nm⁻¹].
Spectrum planckRadiance_W_m2_sr_nm(double temperature_K);

// Band radiance ∫ L_λ dλ over [lo, hi] µm [W m⁻² sr⁻¹], by the exact series for the
// incomplete Planck integral (Widger & Woodall, "Integration of the Planck blackbody radiation
// function", Bull. Am. Meteorol. Soc. 57(10), 1976):
//   ∫_x^∞ t³/(eᵗ−1) dt = Σₙ e^(−n x) (x³/n + 3x²/n² + 6x/n³ + 6/n⁴),  x = h c /(λ k T).
// Over (0, ∞) it is σT⁴/π. Used by the thermal band (8–14 µm) where no grid fits.
double planckBandRadiance_W_m2_sr(double lo_um, double hi_um, double temperature_K);
// d/dT of the band radiance [W m⁻² sr⁻¹ K⁻¹] (the same series, differentiated term by term).
double planckBandRadianceDerivative_W_m2_sr_K(double lo_um, double hi_um, double temperature_K);

// Mean projected area of a cylindrical filament (see above).
double filamentProjectedArea_m2(double radius_m, double length_m);

}  // namespace nvs
