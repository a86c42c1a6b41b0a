#include "sim/lwir/band.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "sim/core/csv.h"
#include "sim/core/error.h"
#include "sim/core/fnv.h"
#include "sim/core/planck.h"

namespace nvs::lwir {
namespace {

constexpr int kSubSteps = 16;
constexpr double kMinBand_um = 1e4 / (Grid::wavenumber_cm1(Grid::kSize - 1));
constexpr double kMaxBand_um = 1e4 / Grid::kFirst_cm1;

}  // namespace

template <typename F>
BandResponse BandResponse::integrate(F response, std::string name) {
    BandResponse b;
    b.name_ = std::move(name);
    for (int i = 0; i < Grid::kSize; ++i) {
        const double nu = Grid::wavenumber_cm1(i);
        const double l0 = 1e4 / (nu + 0.5 * Grid::kStep_cm1);
        const double l1 = 1e4 / (nu - 0.5 * Grid::kStep_cm1);
        const double d = (l1 - l0) / kSubSteps;
        double s = 0.0;
        for (int k = 0; k < kSubSteps; ++k)
            s += response(l0 + (k + 0.5) * d) * d;
        b.w_[i] = s;
    }
    return b;
}

BandResponse BandResponse::flat(double lo_um, double hi_um) {
    if (!(lo_um >= kMinBand_um && hi_um <= kMaxBand_um && lo_um < hi_um)) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "lwir: band [%g, %g] µm is not inside [%.2f, %.2f] µm",
                      lo_um, hi_um, kMinBand_um, kMaxBand_um);
        throw SetupError(buf);
    }
    char name[64];
    std::snprintf(name, sizeof name, "flat %g-%g um", lo_um, hi_um);
    return integrate([=](double l) { return (l >= lo_um && l < hi_um) ? 1.0 : 0.0; }, name);
}

BandResponse BandResponse::fromCsv(const std::filesystem::path& file) {
    const CsvTable t = CsvTable::load(file);
    const std::size_t cl = t.column("wavelength_um"), cr = t.column("response");
    std::vector<double> l, r;
    for (std::size_t i = 0; i < t.rowCount(); ++i) {
        const double li = t.number(i, cl), ri = t.number(i, cr);
        if (!l.empty() && !(li > l.back())) {
            throw SetupError(t.rowLoc(i), "wavelengths must increase");
        }
        if (!(ri >= 0.0)) throw SetupError(t.rowLoc(i), "response must be ≥ 0");
        if (li < kMinBand_um || li > kMaxBand_um) {
            throw SetupError(t.rowLoc(i), "wavelength outside the modelled 6.67–18.2 µm");
        }
        l.push_back(li);
        r.push_back(ri);
    }
    if (l.size() < 2) throw SetupError(t.headerLoc(), "a response needs at least two rows");
    BandResponse b = integrate(
        [&](double x) {
            if (x < l.front() || x > l.back()) return 0.0;
            const auto it = std::upper_bound(l.begin(), l.end(), x);
            if (it == l.end()) return r.back();
            const std::size_t j = static_cast<std::size_t>(it - l.begin());
            const double f = (x - l[j - 1]) / (l[j] - l[j - 1]);
            return r[j - 1] * (1.0 - f) + r[j] * f;
        },
        file.filename().string());
    double sum = 0.0;
    for (int i = 0; i < Grid::kSize; ++i)
        sum += b.w_[i];
    if (!(sum > 0.0)) throw SetupError(t.headerLoc(), "the response is zero everywhere");
    return b;
}

int BandResponse::firstIndex() const {
    int i = 0;
    while (i < Grid::kSize - 1 && !(w_[i] > 0.0))
        ++i;
    return i;
}

int BandResponse::lastIndex() const {
    int i = Grid::kSize - 1;
    while (i > 0 && !(w_[i] > 0.0))
        --i;
    return i;
}

std::uint64_t BandResponse::hash() const {
    Fnv1a f;
    f.bytes(w_.data(), sizeof(double) * w_.size());
    return f.h;
}

double planckGrid_W_m2_sr_um(int i, double temperature_K) {
    return planckSpectralRadiance_W_m2_sr_m(Grid::wavelength_um(i) * 1e-6, temperature_K) * 1e-6;
}

double bandIntegral_W_m2_sr(const BandResponse& band, const Spectral& x, double temperature_K) {
    double s = 0.0;
    for (int i = 0; i < Grid::kSize; ++i) {
        const double w = band.weight_um(i);
        if (w > 0.0) s += w * x[i] * planckGrid_W_m2_sr_um(i, temperature_K);
    }
    return s;
}

double bandRadiance_W_m2_sr(const BandResponse& band, double temperature_K) {
    double s = 0.0;
    for (int i = 0; i < Grid::kSize; ++i) {
        const double w = band.weight_um(i);
        if (w > 0.0) s += w * planckGrid_W_m2_sr_um(i, temperature_K);
    }
    return s;
}

double bandRadianceDerivative_W_m2_sr_K(const BandResponse& band, double temperature_K) {
    // dB/dT = B · x eˣ / ((eˣ − 1) T),  x = h c / (λ k T).
    constexpr double kC2_um_K = 14387.768775;  // h c / k [µm K]
    double s = 0.0;
    for (int i = 0; i < Grid::kSize; ++i) {
        const double w = band.weight_um(i);
        if (w <= 0.0) continue;
        const double x = kC2_um_K / (Grid::wavelength_um(i) * temperature_K);
        s += w * planckGrid_W_m2_sr_um(i, temperature_K) * x / (-std::expm1(-x)) / temperature_K;
    }
    return s;
}

double brightnessTemperature_K(const BandResponse& band, double radiance_W_m2_sr) {
    if (!(radiance_W_m2_sr > 0.0)) return 0.0;
    double t = 280.0;
    for (int k = 0; k < 60; ++k) {
        const double f = bandRadiance_W_m2_sr(band, t) - radiance_W_m2_sr;
        const double step = f / bandRadianceDerivative_W_m2_sr_K(band, t);
        // Newton on a convex, rising curve; halve steps that would leave T > 0.
        t = (t - step > 0.0) ? t - step : 0.5 * t;
        if (std::fabs(step) < 1e-9 * t) break;
    }
    return t;
}

PathBand horizontalPath(const AbsorptionData& data, const BandResponse& band, const AirState& air,
                        double range_m) {
    const Spectral tau = homogeneousTransmittance(data, air, range_m);
    Spectral absorb{};
    for (int i = 0; i < Grid::kSize; ++i)
        absorb[i] = 1.0 - tau[i];
    PathBand out;
    const double bAir = bandRadiance_W_m2_sr(band, air.temperature_K);
    out.transmittance = bandIntegral_W_m2_sr(band, tau, air.temperature_K) / bAir;
    out.pathRadiance_W_m2_sr = bandIntegral_W_m2_sr(band, absorb, air.temperature_K);
    return out;
}

}  // namespace nvs::lwir
