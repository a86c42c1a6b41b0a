#pragma once
// The moonless night sky (docs/design.md §4.2): the thesis's measured spectrum (Appendix G,
// config/spectra/night_sky_thesis_appendix_g.csv; 0.0012 lx on a horizontal surface) split into
// components that can be scaled one by one. With all scales 1 the components add up to the
// Appendix G spectrum exactly in energy (bin by bin outside the 50 nm cells around the lines).
//
// Components, all as zenith spectral radiance [W m⁻² sr⁻¹ nm⁻¹] of a uniform sky:
//   OI 557.7 nm   250 R      } airglow emission lines, typical zenith intensities from
//   OI 630.0 nm    60 R      } Leinert et al. (1998), A&AS 127, 1, §8 (Na D varies 30–100 R
//   Na D 589.3 nm  50 R      } with season); 1 R = 10¹⁰/(4π) photons s⁻¹ m⁻² sr⁻¹
//   starlight       2.2·10⁻⁴ lx   integrated starlight (thesis §5.3 quoting its ref. [72]),
//                                 spectral shape of a 4500 K blackbody (G–K star mix)
//   zodiacal        2.0·10⁻⁴ lx   scattered sunlight: the solar spectrum's shape
//   OH + continuum  the rest: OH Meinel bands (most of the 700–1100 nm excess) and the
//                   airglow pseudo-continuum; Appendix G at 50 nm resolution cannot split them.
// Each line's energy is taken out of the measured spectrum as a 50 nm box centred on it (the
// table's resolution), so the residual stays smooth and the total is preserved.

#include <array>
#include <filesystem>

#include "sim/core/spectrum.h"

namespace nvs::sky {

enum class NightSkyComponent : int {
    OxygenGreen5577 = 0,
    OxygenRed6300,
    SodiumD,
    OhAndContinuum,
    Starlight,
    Zodiacal,
};
inline constexpr int kNightSkyComponentCount = 6;
const char* nightSkyComponentName(NightSkyComponent c);

struct NightSkyScales {
    std::array<double, kNightSkyComponentCount> scale{1.0, 1.0, 1.0, 1.0, 1.0, 1.0};
    double& operator[](NightSkyComponent c) { return scale[static_cast<int>(c)]; }
    double operator[](NightSkyComponent c) const { return scale[static_cast<int>(c)]; }
};

// Rayleigh → radiance at a wavelength: I_R · 10¹⁰/(4π) · h c / λ  [W m⁻² sr⁻¹].
double rayleighToRadiance_W_m2_sr(double intensity_R, double wavelength_nm);

class NightSkyModel {
  public:
    // Setup: loads Appendix G, the solar spectrum and V(λ) from configDir, builds the
    // components; throws SetupError if a component would make the residual negative.
    static NightSkyModel load(const std::filesystem::path& configDir);

    const Spectrum& measured_W_m2_sr_nm() const { return measured_; }
    const Spectrum& component(NightSkyComponent c) const {
        return components_[static_cast<int>(c)];
    }
    // Illuminance on a horizontal surface under a uniform sky of this component, π L [lx].
    double componentIlluminance_lux(NightSkyComponent c) const {
        return componentLux_[static_cast<int>(c)];
    }

    // Per frame (no allocation, no throw).
    void radiance(const NightSkyScales& s, Spectrum& out_W_m2_sr_nm) const noexcept;
    double horizontalIlluminance_lux(const NightSkyScales& s) const noexcept;

  private:
    Spectrum measured_;
    std::array<Spectrum, kNightSkyComponentCount> components_;
    std::array<double, kNightSkyComponentCount> componentLux_{};
};

}  // namespace nvs::sky
