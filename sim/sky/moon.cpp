#include "sim/sky/moon.h"

#include <cmath>

#include "sim/core/photometry.h"
#include "sim/core/units.h"
#include "sim/sky/solar.h"

namespace nvs::sky {

double krisciunasSchaeferMagnitude(double phaseAngle_deg) {
    const double a = std::abs(phaseAngle_deg);
    return -12.73 + 0.026 * a + 4e-9 * a * a * a * a;
}

double illuminanceFromVMagnitude_lux(double vMagnitude) {
    return std::pow(10.0, -0.4 * (vMagnitude + 13.99));
}

double oppositionSurge(double phaseAngle_rad) {
    const double a_deg = std::abs(phaseAngle_rad) * kDegPerRad;
    return 1.0 + kOppositionSurgeAmplitude * std::exp(-a_deg / kOppositionSurgeWidth_deg);
}

double lunarPhaseLaw(double phaseAngle_rad) {
    const double a_deg = std::abs(phaseAngle_rad) * kDegPerRad;
    const double dm = krisciunasSchaeferMagnitude(a_deg) - krisciunasSchaeferMagnitude(0.0);
    return std::pow(10.0, -0.4 * dm) * oppositionSurge(phaseAngle_rad);
}

MoonSource MoonSource::load(const std::filesystem::path& configDir) {
    MoonSource m;
    const Photometry photometry(configDir);
    const Spectrum sun = loadSolarSpectrum_W_m2_nm(configDir);
    const TabulatedSpectrum albedo = loadSpectrumCsv(
        configDir / "spectra" / "lunar_albedo_velikodsky2011.csv", "wavelength_nm", "albedo_rel");
    // Above 1000 nm (end of the table) the albedo is held: the lunar spectrum flattens into the
    // 1 µm pyroxene band there (Velikodsky's highland/mare columns rise by < 5 % to 1050 nm).
    const Spectrum shape = albedo.resample(Extrapolation::Clamp);
    const double omega0_sr =
        kPi * (kMoonRadius_m / kMoonMeanDistance_m) * (kMoonRadius_m / kMoonMeanDistance_m);
    // Step 1: unscaled irradiance with the albedo shape as the reflectance.
    Spectrum e = sun * shape * (omega0_sr / kPi);
    // Step 2: scale so that the photopic illuminance is that of V = −12.73 (α = 0, no surge).
    const double target_lux = illuminanceFromVMagnitude_lux(krisciunasSchaeferMagnitude(0.0));
    const double c = target_lux / photometry.photometricIntegral(e);
    m.reference_ = e * c;
    m.reflectance_ = shape * c;
    m.referenceIlluminance_lux_ = target_lux;
    return m;
}

double MoonSource::geometryFactor(const astro::MoonState& moon) noexcept {
    const double rs = kAu_m / moon.sunDistance_m;
    const double rm = kMoonMeanDistance_m / moon.distanceTopocentric_m;
    return lunarPhaseLaw(moon.phaseAngle_rad) * rs * rs * rm * rm;
}

void MoonSource::spectralIrradianceToa(const astro::MoonState& moon, Spectrum& out) const noexcept {
    const double k = geometryFactor(moon);
    for (int i = 0; i < Spectrum::size(); ++i)
        out[i] = reference_[i] * k;
}

}  // namespace nvs::sky
