#include "sim/core/photometry.h"

#include "sim/core/units.h"

namespace nvs {

Photometry::Photometry(const std::filesystem::path& configDir)
    : v_(loadSpectrumCsv(configDir / "spectra" / "cie1931_2deg_photopic_V_1nm.csv", "wavelength_nm",
                         "V_rel")
             .resample(Extrapolation::Zero)) {}

double Photometry::photometricIntegral(const Spectrum& spectral_per_nm) const {
    return kLuminousEfficacy_lm_W * integrateProduct_nm(spectral_per_nm, v_);
}

}  // namespace nvs
