#include "sim/lwir/sky.h"

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "sim/core/error.h"
#include "sim/core/units.h"
#include "sim/lwir/humidity.h"

namespace nvs::lwir {
namespace {

constexpr double kEarthRadius_m = 6371e3;
constexpr double kTop_m = 40e3;
constexpr double kG_m_s2 = 9.80665;
constexpr double kRDry_J_kg_K = 287.053;        // US Standard Atmosphere 1976
constexpr double kDobson_molec_m2 = 2.6867e20;  // 1 DU
constexpr double kO3Peak_m = 22e3, kO3Sigma_m = 5e3;

struct Layer {
    double z0_m, z1_m;
    AirState air;
    Spectral planck;  // B_λ at the layer's temperature [per µm]
};

double temperatureAt(const SkyParams& s, double z) {
    return s.airTemperature_K - s.lapseRate_K_m * std::min(z, s.tropopause_m);
}

double pressureAt(const SkyParams& s, double z) {
    const double t0 = s.airTemperature_K;
    const double tt = temperatureAt(s, s.tropopause_m);
    const double expo = kG_m_s2 / (kRDry_J_kg_K * s.lapseRate_K_m);
    if (z <= s.tropopause_m) return s.pressure_Pa * std::pow(temperatureAt(s, z) / t0, expo);
    const double pt = s.pressure_Pa * std::pow(tt / t0, expo);
    return pt * std::exp(-kG_m_s2 * (z - s.tropopause_m) / (kRDry_J_kg_K * tt));
}

AirState airAtImpl(const SkyParams& s, double z) {
    AirState a;
    a.temperature_K = temperatureAt(s, z);
    a.pressure_Pa = pressureAt(s, z);
    // Vapour density falls with H_w; the vapour pressure follows at the local temperature.
    const double rho0 = vapourDensity_kg_m3(s.vapourPressure_Pa, s.airTemperature_K);
    const double rho = rho0 * std::exp(-z / s.waterScaleHeight_m);
    const double e = rho * kGasConstant_J_mol_K * a.temperature_K / kMolarMassWater_kg_mol;
    a.vapourPressure_Pa = std::min(e, saturationVapourPressure_Pa(a.temperature_K));
    a.co2_ppm = s.co2_ppm;
    const double nAir_m3 = a.pressure_Pa / (kBoltzmann_J_K * a.temperature_K);
    const double dz = (z - kO3Peak_m) / kO3Sigma_m;
    const double nO3_m3 = s.o3Column_DU * kDobson_molec_m2 / (kO3Sigma_m * std::sqrt(2.0 * kPi)) *
                          std::exp(-0.5 * dz * dz);
    a.o3_ppb = nO3_m3 / nAir_m3 * 1e9 + (z < s.tropopause_m ? s.o3Surface_ppb : 0.0);
    return a;
}

// Layer boundaries: 10 m, growing by 15 % per layer, to 40 km, with the cloud base inserted.
std::vector<Layer> layers(const SkyParams& s) {
    std::vector<double> z = {0.0};
    for (double dz = 10.0; z.back() < kTop_m; dz *= 1.15)
        z.push_back(std::min(kTop_m, z.back() + dz));
    if (s.cloudFraction > 0.0) z.push_back(s.cloudBase_m);
    std::sort(z.begin(), z.end());
    z.erase(std::unique(z.begin(), z.end(), [](double a, double b) { return b - a < 1e-6; }),
            z.end());
    std::vector<Layer> out;
    for (std::size_t k = 0; k + 1 < z.size(); ++k) {
        Layer l{z[k], z[k + 1], airAtImpl(s, 0.5 * (z[k] + z[k + 1])), {}};
        for (int i = 0; i < Grid::kSize; ++i) {
            l.planck[i] = planckGrid_W_m2_sr_um(i, l.air.temperature_K);
        }
        out.push_back(l);
    }
    return out;
}

// Distance along the ray from the ground to radius R + z at zenith θ (spherical shells).
double slantDistance_m(double z_m, double sinZ, double cosZ) {
    const double r = kEarthRadius_m + z_m;
    const double rs = kEarthRadius_m * sinZ;
    return std::sqrt(std::max(0.0, r * r - rs * rs)) - kEarthRadius_m * cosZ;
}

double bandRadianceAt(const BandResponse& band, const SkyParams& s, const std::vector<Layer>& ls,
                      double zenith_rad, PathAbsorption* path) {
    const double sinZ = std::sin(zenith_rad), cosZ = std::cos(zenith_rad);
    Spectral tPrev, lClear{}, lSub{}, tBase{};
    tPrev.fill(1.0);
    tBase.fill(1.0);
    path->reset();
    bool belowBase = s.cloudFraction > 0.0;
    for (const Layer& l : ls) {
        if (belowBase && l.z0_m >= s.cloudBase_m - 1e-6) {
            lSub = lClear;
            tBase = tPrev;
            belowBase = false;
        }
        path->add(l.air, slantDistance_m(l.z1_m, sinZ, cosZ) - slantDistance_m(l.z0_m, sinZ, cosZ));
        for (int i = band.firstIndex(); i <= band.lastIndex(); ++i) {
            const double t = path->transmittance(i);
            lClear[i] += l.planck[i] * (tPrev[i] - t);
            tPrev[i] = t;
        }
    }
    double clear = 0.0, cloudy = 0.0;
    const double tc = s.cloudTemperature_K();
    for (int i = 0; i < Grid::kSize; ++i) {
        const double w = band.weight_um(i);
        if (w <= 0.0) continue;
        clear += w * lClear[i];
        if (s.cloudFraction > 0.0)
            cloudy += w * (lSub[i] + tBase[i] * planckGrid_W_m2_sr_um(i, tc));
    }
    return (1.0 - s.cloudFraction) * clear + s.cloudFraction * cloudy;
}

}  // namespace

AirState airAtHeight(const SkyParams& sky, double height_m) {
    return airAtImpl(sky, std::clamp(height_m, 0.0, kTop_m));
}

std::vector<PathBand> slantPathProfile(const AbsorptionData& data, const BandResponse& band,
                                       const SkyParams& sky, double sensorHeight_m,
                                       double viewZenith_rad, const std::vector<double>& ranges_m) {
    sky.validate();
    if (!(sensorHeight_m >= 0.0 && sensorHeight_m < kTop_m)) {
        throw SetupError("lwir: sensor height " + std::to_string(sensorHeight_m) +
                         " m is outside 0–40 km");
    }
    const double mu = std::cos(viewZenith_rad);
    PathAbsorption path(data);
    path.setActive(band.firstIndex(), band.lastIndex());
    path.reset();
    Spectral tPrev, emitted{};
    tPrev.fill(1.0);
    const double bAir = bandRadiance_W_m2_sr(band, sky.airTemperature_K);
    std::vector<PathBand> out;
    double s0 = 0.0;
    for (double r : ranges_m) {
        if (!(r > s0)) throw SetupError("lwir: slant-path ranges must be positive and increase");
        const double rise = std::fabs(mu) * (r - s0);
        const int n = std::clamp(static_cast<int>(std::ceil(rise / (50.0 + 0.1 * s0))), 1, 400);
        for (int k = 0; k < n; ++k) {
            const double a = s0 + (r - s0) * k / n, b = s0 + (r - s0) * (k + 1) / n;
            const AirState air = airAtHeight(sky, sensorHeight_m + mu * 0.5 * (a + b));
            path.add(air, b - a);
            for (int i = band.firstIndex(); i <= band.lastIndex(); ++i) {
                const double t = path.transmittance(i);
                emitted[i] += planckGrid_W_m2_sr_um(i, air.temperature_K) * (tPrev[i] - t);
                tPrev[i] = t;
            }
        }
        PathBand p;
        p.transmittance = bandIntegral_W_m2_sr(band, tPrev, sky.airTemperature_K) / bAir;
        double l = 0.0;
        for (int i = 0; i < Grid::kSize; ++i)
            l += band.weight_um(i) * emitted[i];
        p.pathRadiance_W_m2_sr = l;
        out.push_back(p);
        s0 = r;
    }
    return out;
}

void SkyParams::validate() const {
    const auto bad = [](const std::string& what) { throw SetupError("lwir sky: " + what); };
    if (!(airTemperature_K > 180.0 && airTemperature_K < 340.0))
        bad("air temperature out of range");
    if (!(vapourPressure_Pa >= 0.0)) bad("water vapour pressure is negative");
    if (!(pressure_Pa > 3e4 && pressure_Pa < 1.1e5)) bad("pressure out of 300–1100 hPa");
    if (!(lapseRate_K_m >= 0.0 && lapseRate_K_m < 0.0098)) bad("lapse rate out of 0–9.8 K/km");
    if (!(tropopause_m > 5e3 && tropopause_m < 20e3)) bad("tropopause out of 5–20 km");
    if (!(airTemperature_K - lapseRate_K_m * tropopause_m > 160.0)) {
        bad("the tropopause would be colder than 160 K (lapse rate × height too large)");
    }
    if (!(waterScaleHeight_m > 100.0)) bad("water-vapour scale height must be > 100 m");
    if (!(co2_ppm >= 0.0 && o3Surface_ppb >= 0.0 && o3Column_DU >= 0.0)) bad("negative gas amount");
    if (!(cloudFraction >= 0.0 && cloudFraction <= 1.0)) bad("cloud fraction outside 0–1");
    if (!(cloudBase_m > 0.0 && cloudBase_m < tropopause_m))
        bad("cloud base outside the troposphere");
}

double SkyParams::cloudTemperature_K() const {
    return airTemperature_K - lapseRate_K_m * cloudBase_m;
}

double skyBandRadiance_W_m2_sr(const AbsorptionData& data, const BandResponse& band,
                               const SkyParams& sky, double zenith_rad) {
    sky.validate();
    const std::vector<Layer> ls = layers(sky);
    PathAbsorption path(data);
    path.setActive(band.firstIndex(), band.lastIndex());
    const double z = std::clamp(zenith_rad, 0.0, 0.5 * kPi);
    return bandRadianceAt(band, sky, ls, z, &path);
}

std::vector<double> skyBandRadianceProfile(const AbsorptionData& data, const BandResponse& band,
                                           const SkyParams& sky, int count) {
    sky.validate();
    if (count < 2) throw SetupError("lwir sky: a profile needs at least two angles");
    const std::vector<Layer> ls = layers(sky);
    PathAbsorption path(data);
    path.setActive(band.firstIndex(), band.lastIndex());
    std::vector<double> out(static_cast<std::size_t>(count));
    for (int k = 0; k < count; ++k) {
        const double z = 0.5 * kPi * k / (count - 1);
        out[static_cast<std::size_t>(k)] = bandRadianceAt(band, sky, ls, z, &path);
    }
    return out;
}

double tiltedSkyRadiance_W_m2_sr(const std::vector<double>& profile, double tilt_rad) {
    // Midpoint sums: 0.5° in θ, 2° in φ; cos γ = cos θ cos β + sin θ sin β cos φ.
    const int n = static_cast<int>(profile.size());
    const double dz = 0.5 * kPi / (n - 1);
    const int nTheta = 180, nPhi = 180;
    const double dTheta = 0.5 * kPi / nTheta, dPhi = 2.0 * kPi / nPhi;
    const double cb = std::cos(tilt_rad), sb = std::sin(tilt_rad);
    double sum = 0.0;
    for (int i = 0; i < nTheta; ++i) {
        const double th = (i + 0.5) * dTheta;
        const double u = th / dz;
        const int k = std::min(static_cast<int>(u), n - 2);
        const double l = profile[static_cast<std::size_t>(k)] * (1.0 - (u - k)) +
                         profile[static_cast<std::size_t>(k) + 1] * (u - k);
        double c = 0.0;
        for (int j = 0; j < nPhi; ++j) {
            const double g = std::cos(th) * cb + std::sin(th) * sb * std::cos((j + 0.5) * dPhi);
            if (g > 0.0) c += g;
        }
        sum += l * c * std::sin(th) * dTheta * dPhi;
    }
    return sum / kPi;
}

double skyBandEmittance(const BandResponse& band, const SkyParams& sky,
                        const std::vector<double>& profile) {
    // ∫ L cosθ dΩ = 2π ∫ L(θ) cosθ sinθ dθ, trapezoid on the profile's angles.
    const int n = static_cast<int>(profile.size());
    const double dz = 0.5 * kPi / (n - 1);
    double f = 0.0;
    for (int k = 0; k < n; ++k) {
        const double z = dz * k;
        const double w = (k == 0 || k == n - 1) ? 0.5 : 1.0;
        f += w * profile[static_cast<std::size_t>(k)] * std::cos(z) * std::sin(z) * dz;
    }
    return 2.0 * kPi * f / (kPi * bandRadiance_W_m2_sr(band, sky.airTemperature_K));
}

}  // namespace nvs::lwir
