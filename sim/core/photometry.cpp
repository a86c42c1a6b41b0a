#include "sim/core/photometry.h"

#include "sim/core/paths.h"
#include "sim/core/units.h"

namespace nvs {

const Spectrum& photopicV() {
    static const Spectrum kV = [] {
        const auto path = configDir() / "spectra" / "cie1931_2deg_photopic_V_1nm.csv";
        return loadSpectrumCsv(path, "wavelength_nm", "V_rel").resample(Extrapolation::Zero);
    }();
    return kV;
}

double photometricIntegral(const Spectrum& spectral_per_nm) {
    return kLuminousEfficacy_lm_W * integrateProduct_nm(spectral_per_nm, photopicV());
}

}  // namespace nvs
