#include "sim/thermal/forcing.h"

#include <algorithm>
#include <cmath>

#include "sim/core/units.h"

namespace nvs::thermal {

namespace {
constexpr double kSolarConstant_W_m2 = 1361.0;  // Kopp & Lean 2011
constexpr double kAu_m = 1.495978707e11;
}  // namespace

double airmassKastenYoung(double zenith_rad) noexcept {
    const double zDeg = zenith_rad * kDegPerRad;
    if (zDeg >= 96.0) return 40.0;
    return 1.0 / (std::cos(zenith_rad) + 0.50572 * std::pow(96.07995 - zDeg, -1.6364));
}

SolarIrradiance clearSkySolar(double apparentZenith_rad, double sunDistance_m,
                              double siteAltitude_m, double linkeTurbidity) noexcept {
    const double cz = std::cos(apparentZenith_rad);
    if (cz <= 0.0) return {};
    const double h = siteAltitude_m, tl = linkeTurbidity;
    const double i0 = kSolarConstant_W_m2 * (kAu_m / sunDistance_m) * (kAu_m / sunDistance_m);
    const double am = airmassKastenYoung(apparentZenith_rad) * std::exp(-h / 8434.5);
    const double fh1 = std::exp(-h / 8000.0), fh2 = std::exp(-h / 1250.0);
    const double cg1 = 5.09e-5 * h + 0.868, cg2 = 3.92e-5 * h + 0.0387;
    SolarIrradiance s;
    s.ghi_W_m2 = cg1 * i0 * cz * std::exp(-cg2 * am * (fh1 + fh2 * (tl - 1.0)));
    const double b = 0.664 + 0.163 / fh1;
    const double bnci = i0 * std::max(0.0, b * std::exp(-0.09 * am * (tl - 1.0)));
    const double bound =
        s.ghi_W_m2 * std::max(0.0, (1.0 - (0.1 - 0.2 * std::exp(-tl)) / (0.1 + 0.882 / fh1)) / cz);
    s.dni_W_m2 = std::min(bnci, bound);
    s.dhi_W_m2 = std::max(0.0, s.ghi_W_m2 - s.dni_W_m2 * cz);
    return s;
}

SolarIrradiance cloudySolar(const SolarIrradiance& clear, double cloudFraction,
                            double cosZenith) noexcept {
    const double c = std::clamp(cloudFraction, 0.0, 1.0);
    if (c <= 0.0 || cosZenith <= 0.0) return clear;
    SolarIrradiance s;
    s.ghi_W_m2 = clear.ghi_W_m2 * (1.0 - 0.75 * std::pow(c, 3.4));
    s.dhi_W_m2 = s.ghi_W_m2 * (0.3 + 0.7 * c * c);
    s.dni_W_m2 = (s.ghi_W_m2 - s.dhi_W_m2) / cosZenith;
    return s;
}

double vapourPressure_hPa(double dewPoint_K) noexcept {
    const double t = dewPoint_K - kCelsiusZero_K;
    return 6.1094 * std::exp(17.625 * t / (t + 243.04));
}

double clearSkyEmissivity(double air_K, double dewPoint_K) noexcept {
    return 1.24 * std::pow(vapourPressure_hPa(dewPoint_K) / air_K, 1.0 / 7.0);
}

double longwaveDown_W_m2(const WeatherSample& w, double lapseRate_K_m) noexcept {
    const double eps = std::min(1.0, clearSkyEmissivity(w.air_K, w.dewPoint_K));
    const double ta4 = w.air_K * w.air_K * w.air_K * w.air_K;
    const double tc = std::max(150.0, w.air_K - lapseRate_K_m * w.cloudBase_m);
    const double tc4 = tc * tc * tc * tc;
    const double c = std::clamp(w.cloudFraction, 0.0, 1.0);
    return kStefanBoltzmann_W_m2_K4 * (eps * ta4 + c * (1.0 - eps) * tc4);
}

double slabHemisphericalEmissivity(double zenithEmissivity) noexcept {
    // 2∫₀^{π/2} ε(θ) cos θ sin θ dθ, midpoint rule in θ (ε(θ) → 1 smoothly at the horizon).
    constexpr int kSteps = 120;
    const double h = 0.5 * kPi / kSteps, tr = 1.0 - zenithEmissivity;
    double sum = 0.0;
    for (int i = 0; i < kSteps; ++i) {
        const double th = (i + 0.5) * h, c = std::cos(th);
        sum += (1.0 - std::pow(tr, 1.0 / c)) * c * std::sin(th);
    }
    return 2.0 * sum * h;
}

double slabZenithEmissivity(double hemisphericalEmissivity) noexcept {
    // The hemispherical mean rises monotonically with ε₀ from 0 to 1: bisection to 1e-8.
    double lo = 0.0, hi = 1.0;
    for (int i = 0; i < 27; ++i) {
        const double mid = 0.5 * (lo + hi);
        (slabHemisphericalEmissivity(mid) < hemisphericalEmissivity ? lo : hi) = mid;
    }
    return 0.5 * (lo + hi);
}

namespace {

// ∫₀^{2π} max(0, a + b cos φ) dφ for b ≥ 0: 2πa when a ≥ b, 0 when a ≤ −b, otherwise
// 2(a φ₀ + b sin φ₀) with cos φ₀ = −a/b.
double positiveCosineIntegral(double a, double b) noexcept {
    if (a >= b) return kTwoPi * a;
    if (a <= -b) return 0.0;
    const double phi0 = std::acos(-a / b);
    return 2.0 * (a * phi0 + b * std::sin(phi0));
}

}  // namespace

double slabMeanEmissivityOnTilt(double zenithEmissivity, double tilt_rad) noexcept {
    // Over the sky (θ < 90°) in front of the plane (cos γ > 0), cos γ = cos β cos θ +
    // sin β sin θ cos φ (φ from the plane's azimuth): the φ integral in closed form, the θ
    // integral by the midpoint rule.
    constexpr int kTheta = 180;
    const double dth = 0.5 * kPi / kTheta, tr = 1.0 - zenithEmissivity;
    const double cb = std::cos(tilt_rad), sb = std::abs(std::sin(tilt_rad));
    double num = 0.0, den = 0.0;
    for (int i = 0; i < kTheta; ++i) {
        const double th = (i + 0.5) * dth, ct = std::cos(th), st = std::sin(th);
        const double w = st * positiveCosineIntegral(cb * ct, sb * st);
        num += (1.0 - std::pow(tr, 1.0 / ct)) * w;
        den += w;
    }
    return den > 0.0 ? num / den : 1.0;
}

TiltedSky::TiltedSky(double tilt_rad) {
    for (int k = 0; k < kTable; ++k) {
        const double eff = 0.3 + 0.01 * k;
        const double e0 = slabZenithEmissivity(eff);
        const double flat = slabMeanEmissivityOnTilt(e0, 0.0);
        table_[k] = flat > 0.0 ? slabMeanEmissivityOnTilt(e0, tilt_rad) / flat : 1.0;
    }
}

double TiltedSky::ratio(double effectiveEmissivity) const noexcept {
    const double u = (std::clamp(effectiveEmissivity, 0.3, 1.0) - 0.3) / 0.01;
    const int i = std::min(static_cast<int>(u), kTable - 2);
    const double f = u - i;
    return table_[i] + f * (table_[i + 1] - table_[i]);
}

double convectionCoefficient_W_m2K(double wind_m_s, double surface_K, double air_K, double cosTilt,
                                   double roughnessMultiplier) noexcept {
    const double dT = surface_K - air_K;
    const double cbrt = std::cbrt(std::abs(dT));
    const double ac = std::abs(cosTilt);
    double hn;
    if (ac < 1e-6) {
        hn = 1.31 * cbrt;
    } else {
        // Heat flows up (unstable) when a surface facing up is warmer than the air, or one
        // facing down is colder.
        const bool unstable = (dT > 0.0) == (cosTilt > 0.0);
        hn = unstable ? 9.482 * cbrt / (7.238 - ac) : 1.810 * cbrt / (1.382 + ac);
    }
    const double forced = 3.26 * std::pow(std::max(0.0, wind_m_s), 0.89);
    const double hGlass = std::sqrt(hn * hn + forced * forced);
    return hn + roughnessMultiplier * (hGlass - hn);
}

double massTransfer_m_s(double hc_W_m2K, double air_K) noexcept {
    constexpr double kRd = 287.05, kCp = 1007.0, kLewis = 0.87;
    const double rhoAir = 101325.0 / (kRd * air_K);
    return hc_W_m2K / (rhoAir * kCp * std::pow(kLewis, 2.0 / 3.0));
}

double latentFlux_W_m2(double conductance_m_s, double surface_K, double air_K,
                       double dewPoint_K) noexcept {
    constexpr double kRv = 461.5;
    const double rhoVapAir = 100.0 * vapourPressure_hPa(dewPoint_K) / (kRv * air_K);
    const double rhoVapSurface = 100.0 * vapourPressure_hPa(surface_K) / (kRv * surface_K);
    return kLatentHeat_J_kg * conductance_m_s * (rhoVapAir - rhoVapSurface);
}

double dewFlux_W_m2(double hc_W_m2K, double surface_K, double air_K, double dewPoint_K) noexcept {
    return latentFlux_W_m2(massTransfer_m_s(hc_W_m2K, air_K), surface_K, air_K, dewPoint_K);
}

ForcingSample forcingAt(const astro::Ephemeris& eph, const astro::AstroTime& t0, double t0_s,
                        const WeatherSeries& weather, const ForcingParams& p, double t_s) noexcept {
    ForcingSample f;
    f.weather = weather.at(t_s);
    const astro::SunMoonState sm = eph.compute(t0.plusSeconds(t_s - t0_s));
    f.sunAz_rad = sm.sun.az_rad;
    f.sunAlt_rad = sm.sun.alt_rad;
    const double zen = 0.5 * kPi - sm.sun.alt_rad;
    const SolarIrradiance clear =
        clearSkySolar(zen, sm.sun.distance_m, p.siteAltitude_m, p.linkeTurbidity);
    f.sun = cloudySolar(clear, f.weather.cloudFraction, std::cos(zen));
    f.longwaveDown_W_m2 = longwaveDown_W_m2(f.weather, p.lapseRate_K_m);
    return f;
}

double planeShortwave_W_m2(const ForcingSample& f, const Orientation& o, double skyView,
                           double sunlitFraction, double groundAlbedo) noexcept {
    // cos θ_i = n·s with n = (sin t sin a, sin t cos a, cos t) in (east, north, up).
    const double ca = std::cos(f.sunAlt_rad);
    const double sx = ca * std::sin(f.sunAz_rad), sy = ca * std::cos(f.sunAz_rad),
                 sz = std::sin(f.sunAlt_rad);
    const double st = std::sin(o.tilt_rad);
    const double cosInc = st * std::sin(o.azimuth_rad) * sx + st * std::cos(o.azimuth_rad) * sy +
                          std::cos(o.tilt_rad) * sz;
    const double beam = sz > 0.0 ? f.sun.dni_W_m2 * std::max(0.0, cosInc) * sunlitFraction : 0.0;
    return beam + f.sun.dhi_W_m2 * skyView + f.sun.ghi_W_m2 * groundAlbedo * (1.0 - skyView);
}

}  // namespace nvs::thermal
