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

namespace {

// Σₙ e^(−n x) (x³/n + 3x²/n² + 6x/n³ + 6/n⁴) = ∫_x^∞ t³/(eᵗ−1) dt, and its derivative in x,
// −x³/(eˣ−1). Terms fall as e^(−n x); below x = 2 many are needed (the series still converges,
// n ≤ 2000 reaches 1e-12 relative for x ≥ 0.01).
double planckTailIntegral(double x) {
    if (x <= 0.0) return kPi * kPi * kPi * kPi / 15.0;
    double sum = 0.0;
    for (int n = 1; n <= 4000; ++n) {
        const double dn = n;
        const double e = std::exp(-dn * x);
        const double term = e * (x * x * x / dn + 3.0 * x * x / (dn * dn) +
                                 6.0 * x / (dn * dn * dn) + 6.0 / (dn * dn * dn * dn));
        sum += term;
        if (term < 1e-16 * sum) break;
    }
    return sum;
}

double radianceScale_W_m2_sr(double temperature_K) {
    // 2 k⁴ T⁴ / (h³ c²): turns ∫ t³/(eᵗ−1) dt into radiance.
    const double kT = kBoltzmann_J_K * temperature_K;
    return 2.0 * kT * kT * kT * kT /
           (kPlanck_J_s * kPlanck_J_s * kPlanck_J_s * kSpeedOfLight_m_s * kSpeedOfLight_m_s);
}

double xOf(double wavelength_um, double temperature_K) {
    return kPlanck_J_s * kSpeedOfLight_m_s /
           (wavelength_um * 1e-6 * kBoltzmann_J_K * temperature_K);
}

}  // namespace

double planckBandRadiance_W_m2_sr(double lo_um, double hi_um, double temperature_K) {
    if (temperature_K <= 0.0 || hi_um <= lo_um) return 0.0;
    // Short wavelength ↔ large x: the band is [x(hi), x(lo)].
    const double xLo = xOf(hi_um, temperature_K);
    const double xHi = lo_um > 0.0 ? xOf(lo_um, temperature_K) : 1e300;
    const double tailHi = xHi > 700.0 ? 0.0 : planckTailIntegral(xHi);
    return radianceScale_W_m2_sr(temperature_K) * (planckTailIntegral(xLo) - tailHi);
}

double planckBandRadianceDerivative_W_m2_sr_K(double lo_um, double hi_um, double temperature_K) {
    if (temperature_K <= 0.0 || hi_um <= lo_um) return 0.0;
    // L = a T⁴ [F(x₁) − F(x₂)], x = b/T, F' = −x³/(eˣ−1):
    // dL/dT = 4 L / T + a T⁴ [F'(x₁) (−x₁/T) − F'(x₂) (−x₂/T)].
    const double L = planckBandRadiance_W_m2_sr(lo_um, hi_um, temperature_K);
    const double a = radianceScale_W_m2_sr(temperature_K);
    auto dF = [](double x) { return x > 700.0 ? 0.0 : -x * x * x / std::expm1(x); };
    const double x1 = xOf(hi_um, temperature_K);
    const double x2 = lo_um > 0.0 ? xOf(lo_um, temperature_K) : 1e300;
    const double t = temperature_K;
    return 4.0 * L / t + a * (dF(x1) * (-x1 / t) - dF(x2) * (-x2 / t));
}

double filamentProjectedArea_m2(double radius_m, double length_m) {
    return 0.25 * (kTwoPi * radius_m * length_m);
}

}  // namespace nvs
