#include "sim/sky/atmosphere.h"

#include <algorithm>
#include <array>
#include <cmath>

#include "sim/core/units.h"

namespace nvs::sky {
namespace {

// Gauss–Legendre nodes and weights on [0, 1], 8 points (from the 8-point rule on [−1, 1]).
constexpr std::array<double, 8> kGl8X = {
    0.01985507175123188, 0.10166676129318664, 0.2372337950418355, 0.4082826787521751,
    0.5917173212478249,  0.7627662049581645,  0.8983332387068134, 0.9801449282487681};
constexpr std::array<double, 8> kGl8W = {
    0.05061426814518813, 0.11119051722668724, 0.15685332293894364, 0.18134189168918100,
    0.18134189168918100, 0.15685332293894364, 0.11119051722668724, 0.05061426814518813};

constexpr double kRayleighScaleHeight_m = 8434.5;  // US Standard Atmosphere, near the ground
constexpr double kWaterScaleHeight_m = 2000.0;
constexpr double kSeaLevelPressure_hPa = 1013.25;
constexpr double kKingDepolarization = 0.0279;  // ρ_n of air, Bodhaine et al. (1999)
constexpr double kOzoneLayerHeight_km = 22.0;   // Bird & Riordan (1986) eq. 2-10
constexpr double kEarthRadius_km = 6370.0;

// Bodhaine, Wood, Dutton & Slusser (1999), eq. 30: Rayleigh optical depth of the whole
// atmosphere at 1013.25 hPa, λ in µm.
double rayleighTauSeaLevel(double wavelength_nm) {
    const double l = wavelength_nm * 1e-3;
    const double l2 = l * l;
    return 0.0021520 * (1.0455996 - 341.29061 / l2 - 0.90230850 * l2) /
           (1.0 + 0.0027059889 / l2 - 85.968563 * l2);
}

// Bird & Riordan (1986) band-saturation forms.
double waterTransmittance(double coef, double water_cm, double airmass) {
    const double aw = coef * water_cm * airmass;
    return std::exp(-0.2385 * aw / std::pow(1.0 + 20.07 * aw, 0.45));
}
double mixedGasTransmittance(double coef, double pressureAirmass) {
    const double au = coef * pressureAirmass;
    return std::exp(-1.41 * au / std::pow(1.0 + 118.3 * au, 0.45));
}
double ozoneAirmass(double zenith_rad) {
    const double h = kOzoneLayerHeight_km / kEarthRadius_km;
    const double c = std::cos(zenith_rad);
    return (1.0 + h) / std::sqrt(c * c + 2.0 * h);
}

}  // namespace

AerosolModel parseAerosolModel(std::string_view name, const FileLoc& loc) {
    if (name == "rural") return AerosolModel::Rural;
    if (name == "urban") return AerosolModel::Urban;
    if (name == "maritime") return AerosolModel::Maritime;
    throw SetupError(loc, "unknown aerosol model '" + std::string(name) +
                              "' (expected rural, urban or maritime)");
}

const char* aerosolModelName(AerosolModel m) {
    switch (m) {
        case AerosolModel::Rural:
            return "rural";
        case AerosolModel::Urban:
            return "urban";
        case AerosolModel::Maritime:
            return "maritime";
    }
    return "?";
}

AerosolOptics aerosolOptics(AerosolModel m) {
    switch (m) {
        case AerosolModel::Rural:
            return {1.14, 0.945, 0.65};
        case AerosolModel::Urban:
            return {1.0, 0.80, 0.70};
        case AerosolModel::Maritime:
            return {0.5, 0.99, 0.75};
    }
    return {1.14, 0.945, 0.65};
}

void AtmosphereParams::validate() const {
    const auto bad = [](const std::string& what) { throw SetupError("atmosphere: " + what); };
    if (!(visibility_km > 0.0) || !std::isfinite(visibility_km)) {
        bad("visibility_km must be positive, is " + std::to_string(visibility_km));
    }
    if (!(siteAltitude_m > -500.0 && siteAltitude_m < 9000.0)) {
        bad("site altitude must be between -500 and 9000 m, is " + std::to_string(siteAltitude_m));
    }
    if (!(aerosolScaleHeight_m > 0.0)) bad("aerosol scale height must be positive");
    if (!(ozone_DU >= 0.0)) bad("ozone_DU must be >= 0");
    if (!(precipitableWater_cm >= 0.0)) bad("precipitable water must be >= 0");
    if (!(cloudOpticalDepth >= 0.0)) bad("cloud optical depth must be >= 0");
    if (!(cloudAsymmetry >= 0.0 && cloudAsymmetry < 1.0)) bad("cloud asymmetry must be in [0, 1)");
    if (!(groundAlbedo >= 0.0 && groundAlbedo <= 1.0)) bad("ground albedo must be in [0, 1]");
}

double airmassKastenYoung(double zenith_rad) {
    const double z_deg = zenith_rad * kDegPerRad;
    if (z_deg >= 96.0) return 40.0;
    if (z_deg <= 0.0) return 1.0;
    return 1.0 / (std::cos(zenith_rad) + 0.50572 * std::pow(96.07995 - z_deg, -1.6364));
}

double rayleighPhase(double cosScatter) {
    const double gamma = kKingDepolarization / (2.0 - kKingDepolarization);
    return 3.0 / (4.0 * (1.0 + 2.0 * gamma)) *
           ((1.0 + 3.0 * gamma) + (1.0 - gamma) * cosScatter * cosScatter);
}

double henyeyGreensteinPhase(double cosScatter, double g) {
    const double d = 1.0 + g * g - 2.0 * g * cosScatter;
    return (1.0 - g * g) / (d * std::sqrt(d));
}

TwoStream deltaEddington(double tau, double omega, double g, double mu0) {
    // δ-scaling (Joseph, Wiscombe & Weinman 1976): f = g², the forward peak moved to the beam.
    const double f = g * g;
    const double tauS = (1.0 - omega * f) * tau;
    const double omegaS = std::min((1.0 - f) * omega / (1.0 - omega * f), 1.0 - 1e-9);
    const double gS = (g - f) / (1.0 - f);
    // Eddington coefficients (Meador & Weaver 1980, Table 1).
    const double g1 = (7.0 - omegaS * (4.0 + 3.0 * gS)) / 4.0;
    const double g2 = -(1.0 - omegaS * (4.0 - 3.0 * gS)) / 4.0;
    const double g3 = (2.0 - 3.0 * gS * mu0) / 4.0;
    const double g4 = 1.0 - g3;
    const double a1 = g1 * g4 + g2 * g3;
    const double a2 = g1 * g3 + g2 * g4;
    const double k = std::sqrt(std::max(g1 * g1 - g2 * g2, 1e-18));
    // Avoid the removable singularity at kμ0 = 1.
    double mu = mu0;
    if (std::fabs(1.0 - k * mu) < 1e-6) mu *= 1.0 + 1e-5;
    // Meador & Weaver (1980) eqs. 14–15, with numerator and denominator divided by e^{kτ}
    // so that thick layers do not overflow.
    const double e2k = std::exp(-2.0 * k * tauS);
    const double ek = std::exp(-k * tauS);
    const double eb = std::exp(-tauS / mu);
    const double den = (1.0 - k * k * mu * mu) * ((k + g1) + (k - g1) * e2k);
    const double r = omegaS / den *
                     ((1.0 - k * mu) * (a2 + k * g3) - (1.0 + k * mu) * (a2 - k * g3) * e2k -
                      2.0 * k * (g3 - a2 * mu) * eb * ek);
    const double tDifS =
        -omegaS / den *
        ((1.0 + k * mu) * (a1 + k * g4) * eb - (1.0 - k * mu) * (a1 - k * g4) * eb * e2k -
         2.0 * k * (g4 + a1 * mu) * ek);
    const double tDir = std::exp(-tau / mu0);
    // Light scattered into the forward peak (removed by δ-scaling) is diffuse, not direct.
    const double tDif = std::max(0.0, tDifS + eb - tDir);
    return {std::max(0.0, r), tDif, tDir};
}

double sphericalAlbedo(double tau, double omega, double g) {
    double s = 0.0;
    for (std::size_t i = 0; i < kGl8X.size(); ++i) {
        s += kGl8W[i] * deltaEddington(tau, omega, g, kGl8X[i]).reflectance * kGl8X[i];
    }
    return 2.0 * s;
}

double diffuseTransmittanceIsotropic(double tau, double omega, double g) {
    double s = 0.0;
    for (std::size_t i = 0; i < kGl8X.size(); ++i) {
        const TwoStream t = deltaEddington(tau, omega, g, kGl8X[i]);
        s += kGl8W[i] * (t.directTransmittance + t.diffuseTransmittance) * kGl8X[i];
    }
    return 2.0 * s;
}

Atmosphere::Atmosphere(const AtmosphereParams& params, const std::filesystem::path& configDir)
    : params_(params), aerosol_(aerosolOptics(params.aerosol)) {
    params_.validate();
    pressure_hPa_ =
        kSeaLevelPressure_hPa * std::exp(-params_.siteAltitude_m / kRayleighScaleHeight_m);
    ozone_atm_cm_ = params_.ozone_DU * 1e-3;
    water_cm_ =
        params_.precipitableWater_cm * std::exp(-params_.siteAltitude_m / kWaterScaleHeight_m);

    const auto path = configDir / "atmosphere" / "spectrl2_bird_riordan_1986.csv";
    coefWater_ = loadSpectrumCsv(path, "wavelength_nm", "water_coefficient_rel")
                     .resample(Extrapolation::Clamp);
    coefOzone_ = loadSpectrumCsv(path, "wavelength_nm", "ozone_coefficient_rel")
                     .resample(Extrapolation::Clamp);
    coefMixed_ = loadSpectrumCsv(path, "wavelength_nm", "mixed_gas_coefficient_rel")
                     .resample(Extrapolation::Clamp);

    // Koschmieder: V = 3.912/β_ext(550 nm); the aerosol part is what the molecules leave.
    const double pressureRatio = pressure_hPa_ / kSeaLevelPressure_hPa;
    const double betaRayleighSurface_per_km =
        rayleighTauSeaLevel(550.0) / (kRayleighScaleHeight_m * 1e-3) * pressureRatio;
    const double betaAerosol_per_km =
        std::max(0.0, 3.912 / params_.visibility_km - betaRayleighSurface_per_km);
    const double tauAerosol550 = betaAerosol_per_km * params_.aerosolScaleHeight_m * 1e-3;

    const double mo1 = ozoneAirmass(0.0);
    for (int i = 0; i < Spectrum::size(); ++i) {
        const double wl = SpectralGrid::wavelength_nm(i);
        tauRayleigh_[i] = rayleighTauSeaLevel(wl) * pressureRatio;
        tauAerosol_[i] = tauAerosol550 * std::pow(wl / 550.0, -aerosol_.angstromExponent);
        const double tAbs = std::exp(-coefOzone_[i] * ozone_atm_cm_ * mo1) *
                            waterTransmittance(coefWater_[i], water_cm_, 1.0) *
                            mixedGasTransmittance(coefMixed_[i], pressureRatio);
        tauAbsorption_[i] = -std::log(tAbs);
    }
    cloudIsotropicT_ =
        params_.cloudOpticalDepth > 0.0
            ? diffuseTransmittanceIsotropic(params_.cloudOpticalDepth, 1.0, params_.cloudAsymmetry)
            : 1.0;
}

Spectrum Atmosphere::directTransmittance(double zenith_rad) const {
    Spectrum t;
    if (zenith_rad * kDegPerRad >= 96.0) return t;
    const double m = airmassKastenYoung(zenith_rad);
    const double mo = ozoneAirmass(std::min(zenith_rad, kPi / 2));
    const double pressureAirmass = m * pressure_hPa_ / kSeaLevelPressure_hPa;
    const double cloud = std::exp(-params_.cloudOpticalDepth * m);
    for (int i = 0; i < Spectrum::size(); ++i) {
        t[i] = std::exp(-(tauRayleigh_[i] + tauAerosol_[i]) * m) *
               std::exp(-coefOzone_[i] * ozone_atm_cm_ * mo) *
               waterTransmittance(coefWater_[i], water_cm_, m) *
               mixedGasTransmittance(coefMixed_[i], pressureAirmass) * cloud;
    }
    return t;
}

void Atmosphere::singleScatterRadiancePerIrradiance(double viewZenith_rad, double sourceZenith_rad,
                                                    double cosScatter, Spectrum* out) const {
    // L = E0 · ϖP(ψ)/(4π) · m_v (e^{−τ m_v} − e^{−τ m_s}) / (m_s − m_v): the integral over
    // optical depth t from the top of E0 e^{−t m_s} · ϖP/(4π) · e^{−(τ−t) m_v} · m_v dt,
    // with ϖP = (τ_R P_R + ω_a τ_a P_a)/τ and τ the total (scattering + absorption) depth.
    if (sourceZenith_rad * kDegPerRad >= 96.0 || viewZenith_rad * kDegPerRad >= 90.0) {
        *out = Spectrum();
        return;
    }
    const double ms = airmassKastenYoung(sourceZenith_rad);
    const double mv = airmassKastenYoung(viewZenith_rad);
    const double pR = rayleighPhase(cosScatter);
    const double pA = henyeyGreensteinPhase(cosScatter, aerosol_.asymmetry);
    const double omegaA = aerosol_.singleScatteringAlbedo;
    const double cloud = std::exp(-params_.cloudOpticalDepth * ms);
    const double dm = ms - mv;
    for (int i = 0; i < Spectrum::size(); ++i) {
        const double tauSca = tauRayleigh_[i] * pR + omegaA * tauAerosol_[i] * pA;  // τ·ϖP
        const double tau = tauRayleigh_[i] + tauAerosol_[i] + tauAbsorption_[i];
        double path = 0.0;
        if (std::fabs(dm * tau) < 1e-7) {
            path = mv * std::exp(-tau * mv);  // limit m_s → m_v, per unit τ
        } else {
            path = mv * (std::exp(-tau * mv) - std::exp(-tau * ms)) / (dm * tau);
        }
        (*out)[i] = tauSca * path * cloud / (4.0 * kPi);
    }
}

Spectrum Atmosphere::singleScatterHorizontalPerIrradiance(double sourceZenith_rad) const {
    // ∫ L cosθ dΩ over the upper hemisphere: Gauss–Legendre in μ = cos θ (8 points) and in
    // azimuth relative to the source over [0, π] (16 points, ×2 by symmetry).
    Spectrum sum;
    Spectrum l;
    constexpr int kAz = 16;
    for (int a = 0; a < kAz; ++a) {
        // Midpoint rule in azimuth is spectrally accurate for periodic smooth integrands.
        const double phi = kPi * (a + 0.5) / kAz;
        for (std::size_t j = 0; j < kGl8X.size(); ++j) {
            const double mu = kGl8X[j];
            const double theta = std::acos(mu);
            const double cosPsi = mu * std::cos(sourceZenith_rad) + std::sqrt(1.0 - mu * mu) *
                                                                        std::sin(sourceZenith_rad) *
                                                                        std::cos(phi);
            singleScatterRadiancePerIrradiance(theta, sourceZenith_rad, cosPsi, &l);
            sum += l * (kGl8W[j] * mu * (2.0 * kPi / kAz));
        }
    }
    return sum;
}

void Atmosphere::isotropicRadiancePerIrradiance(double sourceZenith_rad, Spectrum* out) const {
    *out = Spectrum();
    if (sourceZenith_rad * kDegPerRad >= 96.0) return;
    const double ms = airmassKastenYoung(sourceZenith_rad);
    const double mu0 = 1.0 / ms;
    const double cloudDirect = std::exp(-params_.cloudOpticalDepth * ms);
    const Spectrum ss = singleScatterHorizontalPerIrradiance(sourceZenith_rad);
    // The cloud's diffuse light on top of the clear column, per unit TOA irradiance.
    double cloudDiffuse = 0.0;
    if (params_.cloudOpticalDepth > 0.0) {
        const TwoStream c =
            deltaEddington(params_.cloudOpticalDepth, 1.0, params_.cloudAsymmetry, mu0);
        cloudDiffuse = mu0 * c.diffuseTransmittance;
    }
    const double rho = params_.groundAlbedo;
    const double omegaA = aerosol_.singleScatteringAlbedo;
    for (int i = 0; i < Spectrum::size(); ++i) {
        const double tauR = tauRayleigh_[i];
        const double tauA = tauAerosol_[i];
        const double tau = tauR + tauA + tauAbsorption_[i];
        const double sca = tauR + omegaA * tauA;
        const double omega = sca / tau;
        const double g = omegaA * tauA * aerosol_.asymmetry / sca;
        const TwoStream t = deltaEddington(tau, omega, g, mu0);
        const double sbar = sphericalAlbedo(tau, omega, g);
        // Diffuse irradiance at the ground per unit TOA normal irradiance, with the ground's
        // reflections trapped between ground and sky: E = μ0 [T_dif + T_tot ρ s̄ / (1 − ρ s̄)].
        const double tTot = t.directTransmittance + t.diffuseTransmittance;
        const double eTwoStream =
            mu0 * (t.diffuseTransmittance + tTot * rho * sbar / (1.0 - rho * sbar)) * cloudDirect;
        const double excess = std::max(0.0, eTwoStream - ss[i]);
        double lIso = excess / kPi;
        if (cloudDiffuse > 0.0) {
            lIso += cloudDiffuse * diffuseTransmittanceIsotropic(tau, omega, g) /
                    (1.0 - rho * sbar) / kPi;
        }
        (*out)[i] = lIso;
    }
}

void Atmosphere::skyRadiancePerIrradiance(double viewZenith_rad, double sourceZenith_rad,
                                          double cosScatter, Spectrum* out) const {
    singleScatterRadiancePerIrradiance(viewZenith_rad, sourceZenith_rad, cosScatter, out);
    Spectrum iso;
    isotropicRadiancePerIrradiance(sourceZenith_rad, &iso);
    *out += iso;
}

Spectrum Atmosphere::diffuseHorizontalPerIrradiance(double sourceZenith_rad) const {
    Spectrum iso;
    isotropicRadiancePerIrradiance(sourceZenith_rad, &iso);
    return singleScatterHorizontalPerIrradiance(sourceZenith_rad) + iso * kPi;
}

void Atmosphere::extinctionAtHeight(double height_m, Spectrum* out) const {
    const double h = std::max(0.0, height_m);
    const double fR = std::exp(-h / kRayleighScaleHeight_m) / kRayleighScaleHeight_m;
    const double fA = std::exp(-h / params_.aerosolScaleHeight_m) / params_.aerosolScaleHeight_m;
    for (int i = 0; i < Spectrum::size(); ++i) {
        (*out)[i] = tauRayleigh_[i] * fR + tauAerosol_[i] * fA;
    }
}

}  // namespace nvs::sky
