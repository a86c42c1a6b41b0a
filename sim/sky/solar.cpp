#include "sim/sky/solar.h"

namespace nvs::sky {

Spectrum loadSolarSpectrum_W_m2_nm(const std::filesystem::path& configDir) {
    const TabulatedSpectrum t =
        loadSpectrumCsv(configDir / "spectra" / "astm_g173_etr_solar_350_1100nm.csv",
                        "wavelength_nm", "irradiance_W_m-2_nm-1");
    return t.resample(Extrapolation::Clamp);
}

double sunIlluminanceToa_lux(const Photometry& photometry, const Spectrum& solarAt1Au_W_m2_nm,
                             double sunDistance_m) {
    const double r = kAu_m / sunDistance_m;
    return photometry.photometricIntegral(solarAt1Au_W_m2_nm) * r * r;
}

}  // namespace nvs::sky
