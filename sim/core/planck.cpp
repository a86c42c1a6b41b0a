#include "sim/core/planck.h"

#include <cmath>

#include "sim/core/units.h"

namespace nvs {

double planckSpectralRadiance_W_m2_sr_m(double wavelength_m, double temperature_K) {
    if (wavelength_m <= 0.0 || temperature_K <= 0.0) return 0.0;
    const double x =
        kPlanck_J_s * kSpeedOfLight_m_s / (wavelength_m * kBoltzmann_J_K * temperature_K);
    const double l5 = std::pow(wavelength_m, 5);
    // expm1 keeps precision in the Rayleigh–Jeans limit (x ≪ 1).
    return 2.0 * kPlanck_J_s * kSpeedOfLight_m_s * kSpeedOfLight_m_s / (l5 * std::expm1(x));
}

double planckSpectralExitance_W_m2_nm(double wavelength_nm, double temperature_K) {
    return kPi * planckSpectralRadiance_W_m2_sr_nm(wavelength_nm, temperature_K);
}

double planckSpectralIntensity_W_sr_nm(double wavelength_nm, double temperature_K,
                                       double projectedArea_m2) {
    return planckSpectralRadiance_W_m2_sr_nm(wavelength_nm, temperature_K) * projectedArea_m2;
}

double planckSpectralPhotonRadiance_nm(double wavelength_nm, double temperature_K) {
    const double photonEnergy_J = kPlanck_J_s * kSpeedOfLight_m_s / (wavelength_nm * 1e-9);
    return planckSpectralRadiance_W_m2_sr_nm(wavelength_nm, temperature_K) / photonEnergy_J;
}

Spectrum planckRadiance_W_m2_sr_nm(double temperature_K) {
    return Spectrum::fromFunction([temperature_K](double wl_nm) {
        return planckSpectralRadiance_W_m2_sr_nm(wl_nm, temperature_K);
    });
}

double filamentProjectedArea_m2(double radius_m, double length_m) {
    return 0.25 * (kTwoPi * radius_m * length_m);
}

}  // namespace nvs
