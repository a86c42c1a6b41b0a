#pragma once
// Photometry with the CIE photopic luminous efficiency function V(λ) (CIE 1924, identical to
// the ȳ(λ) of the CIE 1931 2° observer), K_m = 683 lm/W:
//
//   X_v = K_m ∫ X_e,λ(λ) V(λ) dλ
//
// A spectral radiance [W m⁻² sr⁻¹ nm⁻¹] gives luminance [cd m⁻²]; a spectral irradiance
// [W m⁻² nm⁻¹] gives illuminance [lx]; a spectral flux [W nm⁻¹] gives luminous flux [lm].

#include "sim/core/spectrum.h"

namespace nvs {

// V(λ) on the grid, from config/spectra/cie1931_2deg_photopic_V_1nm.csv (zero above 780 nm,
// where the table ends and V < 1.5e-5). Loaded once; throws SetupError if the file is missing.
const Spectrum& photopicV();

// K_m ∫ s(λ) V(λ) dλ.
double photometricIntegral(const Spectrum& spectral_per_nm);

}  // namespace nvs
