#pragma once
// Photometry with the CIE photopic luminous efficiency function V(λ) (CIE 1924, identical to
// the ȳ(λ) of the CIE 1931 2° observer), K_m = 683 lm/W:
//
//   X_v = K_m ∫ X_e,λ(λ) V(λ) dλ
//
// A spectral radiance [W m⁻² sr⁻¹ nm⁻¹] gives luminance [cd m⁻²]; a spectral irradiance
// [W m⁻² nm⁻¹] gives illuminance [lx]; a spectral flux [W nm⁻¹] gives luminous flux [lm].

#include <filesystem>

#include "sim/core/spectrum.h"

namespace nvs {

class Photometry {
  public:
    // Setup: V(λ) on the grid from <configDir>/spectra/cie1931_2deg_photopic_V_1nm.csv (zero
    // above 780 nm, where the table ends and V < 1.5e-5); throws SetupError if it is missing.
    explicit Photometry(const std::filesystem::path& configDir);

    const Spectrum& photopicV() const { return v_; }
    // K_m ∫ s(λ) V(λ) dλ.
    double photometricIntegral(const Spectrum& spectral_per_nm) const;

  private:
    Spectrum v_;
};

}  // namespace nvs
