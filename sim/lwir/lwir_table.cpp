#include "sim/lwir/lwir_table.h"

#include <unistd.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "sim/core/error.h"
#include "sim/core/fnv.h"
#include "sim/core/table_file.h"
#include "sim/core/units.h"
#include "sim/lwir/humidity.h"

namespace nvs::lwir {
namespace {

constexpr char kMagic[8] = {'N', 'V', 'S', 'L', 'W', 'I', 'R', 'T'};
constexpr TableFileFormat kFileFormat{kMagic, LwirTable::kFormatVersion, 0xcbf29ce484222325ull,
                                      "LWIR"};  // the cache file (sim/core/table_file.h)
inline double logSpan() {
    return std::log(LwirTable::kMaxRange_m / LwirTable::kMinRange_m);
}

std::uint64_t hashInputs(const LwirTableInputs& in, const AbsorptionData& data) {
    Fnv1a f;
    const std::uint32_t v = LwirTable::kFormatVersion;
    f.bytes(&v, sizeof v);
    const std::uint64_t d = data.hash(), b = in.band.hash();
    f.bytes(&d, sizeof d);
    f.bytes(&b, sizeof b);
    f.bytes(&in.air, sizeof in.air);  // all doubles: no padding
    f.bytes(&in.sky, sizeof in.sky);
    const unsigned char slant = in.slantPaths ? 1 : 0;
    f.bytes(&slant, 1);
    return f.h;
}

double rangeAt(int k) {
    return LwirTable::kMinRange_m * std::exp(logSpan() * k / (LwirTable::kRanges - 1));
}

// log₂ x of a positive normal double, to 3e-6: the exponent bits, and for the mantissa m in
// [1, 2) the series log₂ m = (2/ln 2)(t + t³/3 + t⁵/5 + t⁷/7 + t⁹/9), t = (m − 1)/(m + 1) < 1/3
// (truncation below 3e-6). Only a table position depends on it, and values are interpolated
// between the right nodes whatever the error, so it replaces libm's log on the per-pixel path.
inline double fastLog2(double x) {
    const auto b = std::bit_cast<std::uint64_t>(x);
    const double e = static_cast<double>(static_cast<int>((b >> 52) & 0x7ff) - 1023);
    const double m = std::bit_cast<double>((b & 0x000fffffffffffffull) | 0x3ff0000000000000ull);
    const double t = (m - 1.0) / (m + 1.0), t2 = t * t;
    constexpr double kTwoOverLn2 = 2.8853900817779268;  // 2 / ln 2
    return e + kTwoOverLn2 * t * (1.0 + t2 * (1.0 / 3 + t2 * (0.2 + t2 * (1.0 / 7 + t2 / 9))));
}

// Position of a range (≥ 1 m) on the log-spaced range grid.
inline void rangePos(double range_m, double scale, int* i, double* f) {
    double u = fastLog2(range_m / LwirTable::kMinRange_m) * scale;
    u = std::min(u, LwirTable::kRanges - 1 - 1e-9);
    *i = static_cast<int>(u);
    *f = u - *i;
}

constexpr double kSlantZenithStep_rad = 3.0 * kRadPerDeg;

void buildSlant(const LwirTableInputs& in, const AbsorptionData& data, std::vector<double>* lt,
                std::vector<double>* lp) {
    std::vector<double> ranges;
    for (int k = 0; k < LwirTable::kRanges; ++k)
        ranges.push_back(rangeAt(k));
    for (double h : LwirTable::kSlantHeights_m) {
        for (int iz = 0; iz < LwirTable::kSlantZeniths; ++iz) {
            const auto p =
                slantPathProfile(data, in.band, in.sky, h, iz * kSlantZenithStep_rad, ranges);
            for (const PathBand& b : p) {
                lt->push_back(b.transmittance);
                lp->push_back(b.pathRadiance_W_m2_sr);
            }
        }
    }
}

void validateAir(const AirState& a) {
    if (!(a.vapourPressure_Pa >= 0.0)) throw SetupError("lwir: water vapour pressure is negative");
    if (!(a.temperature_K > 180.0 && a.temperature_K < 340.0)) {
        throw SetupError("lwir: air temperature out of 180–340 K");
    }
    if (!(a.pressure_Pa > 3e4 && a.pressure_Pa < 1.1e5)) {
        throw SetupError("lwir: pressure out of 300–1100 hPa");
    }
    if (!(a.co2_ppm >= 0.0 && a.o3_ppb >= 0.0)) throw SetupError("lwir: negative gas amount");
}

}  // namespace

LwirTableInputs LwirTableInputs::fromWeather(double airTemperature_K, double dewPoint_K,
                                             double pressure_Pa, double cloudFraction,
                                             double cloudBase_m, const BandResponse& band) {
    if (!(dewPoint_K <= airTemperature_K + 0.1)) {
        throw SetupError("lwir: dew point " + std::to_string(dewPoint_K) +
                         " K is above the air temperature " + std::to_string(airTemperature_K) +
                         " K");
    }
    LwirTableInputs in;
    in.air.temperature_K = airTemperature_K;
    in.air.pressure_Pa = pressure_Pa;
    in.air.vapourPressure_Pa = vapourPressureFromDewPoint_Pa(dewPoint_K);
    in.sky.airTemperature_K = airTemperature_K;
    in.sky.pressure_Pa = pressure_Pa;
    in.sky.vapourPressure_Pa = in.air.vapourPressure_Pa;
    in.sky.co2_ppm = in.air.co2_ppm;
    in.sky.cloudFraction = cloudFraction;
    in.sky.cloudBase_m = cloudBase_m;
    in.band = band;
    validateAir(in.air);
    in.sky.validate();
    return in;
}

std::string LwirTable::cacheKey(const LwirTableInputs& inputs,
                                const std::filesystem::path& configDir) {
    char buf[17];
    std::snprintf(
        buf, sizeof buf, "%016llx",
        static_cast<unsigned long long>(hashInputs(inputs, AbsorptionData::load(configDir))));
    return buf;
}

LwirTable LwirTable::build(const LwirTableInputs& in, const std::filesystem::path& configDir) {
    validateAir(in.air);
    in.sky.validate();
    const AbsorptionData data = AbsorptionData::load(configDir);
    LwirTable t;
    for (int k = 0; k < kRanges; ++k) {
        const PathBand p = horizontalPath(data, in.band, in.air, rangeAt(k));
        t.tau_.push_back(p.transmittance);
        t.path_.push_back(p.pathRadiance_W_m2_sr);
    }
    t.sky_ = skyBandRadianceProfile(data, in.band, in.sky, kZeniths);
    t.skyEmittance_ = skyBandEmittance(in.band, in.sky, t.sky_);
    t.skyDiffuse_ = t.skyEmittance_ * bandRadiance_W_m2_sr(in.band, in.sky.airTemperature_K);
    for (int k = 0; k < kTilts; ++k) {
        t.tilted_.push_back(lwir::tiltedSkyRadiance_W_m2_sr(t.sky_, k * 5.0 * kRadPerDeg));
    }
    if (in.slantPaths) buildSlant(in, data, &t.slantTau_, &t.slantPath_);
    for (int k = 0; k < kTemperatures; ++k) {
        t.planck_.push_back(
            bandRadiance_W_m2_sr(in.band, kMinTemperature_K + kTemperatureStep_K * k));
    }
    return t;
}

PathBand LwirTable::path(double range_m) const {
    PathBand out;
    if (!(range_m > 0.0)) return out;
    if (range_m < kMinRange_m) {
        const double f = range_m / kMinRange_m;
        out.transmittance = 1.0 - f * (1.0 - tau_[0]);
        out.pathRadiance_W_m2_sr = f * path_[0];
        return out;
    }
    int i = 0;
    double f = 0.0;
    rangePos(range_m, rangeScale_, &i, &f);
    out.transmittance = tau_[i] * (1.0 - f) + tau_[i + 1] * f;
    out.pathRadiance_W_m2_sr = path_[i] * (1.0 - f) + path_[i + 1] * f;
    return out;
}

PathBand LwirTable::slantPath(double sensorHeight_m, double viewZenith_rad, double range_m) const {
    if (slantTau_.empty()) return path(range_m);
    PathBand out;
    if (!(range_m > 0.0)) return out;
    // Height: linear between the tabulated heights, clamped to 0–3 km.
    int ih = 0;
    while (ih < kSlantHeights - 2 && !(sensorHeight_m < kSlantHeights_m[ih + 1]))
        ++ih;
    double fh =
        (sensorHeight_m - kSlantHeights_m[ih]) / (kSlantHeights_m[ih + 1] - kSlantHeights_m[ih]);
    fh = (fh > 0.0) ? std::min(fh, 1.0) : 0.0;
    double uz = viewZenith_rad / kSlantZenithStep_rad;
    uz = (uz > 0.0) ? std::min(uz, kSlantZeniths - 1 - 1e-9) : 0.0;
    const int iz = static_cast<int>(uz);
    const double fz = uz - iz;
    // Below 1 m: linear in r from (τ = 1, L = 0) to the 1 m node.
    const bool near = range_m < kMinRange_m;
    int ir = 0;
    double fr = 0.0;
    if (!near) rangePos(range_m, rangeScale_, &ir, &fr);
    // τ and L linear in ln r (as path()) and bilinear in height and angle: one set of weights
    // for both, which keeps τ B(T) + L_path = B(T) exact for isothermal air.
    double tau = 0.0, l = 0.0;
    for (int dh = 0; dh < 2; ++dh) {
        for (int dz = 0; dz < 2; ++dz) {
            const double w = (dh ? fh : 1.0 - fh) * (dz ? fz : 1.0 - fz);
            const std::size_t row =
                (static_cast<std::size_t>(ih + dh) * kSlantZeniths + iz + dz) * kRanges;
            if (near) {
                const double f = range_m / kMinRange_m;
                tau += w * (1.0 - f * (1.0 - slantTau_[row]));
                l += w * f * slantPath_[row];
            } else {
                tau += w * (slantTau_[row + ir] * (1.0 - fr) + slantTau_[row + ir + 1] * fr);
                l += w * (slantPath_[row + ir] * (1.0 - fr) + slantPath_[row + ir + 1] * fr);
            }
        }
    }
    out.transmittance = tau;
    out.pathRadiance_W_m2_sr = l;
    return out;
}

double LwirTable::tiltedSkyRadiance_W_m2_sr(double tilt_rad) const {
    double u = tilt_rad * kDegPerRad / 5.0;
    u = (u > 0.0) ? std::min(u, kTilts - 1 - 1e-9) : 0.0;
    const int i = static_cast<int>(u);
    const double f = u - i;
    return tilted_[i] * (1.0 - f) + tilted_[i + 1] * f;
}

double LwirTable::skyRadiance_W_m2_sr(double zenith_rad) const {
    // NaN and negative angles read the zenith (no undefined float-to-int conversion).
    double u = zenith_rad * kDegPerRad;
    if (!(u > 0.0)) u = 0.0;
    u = std::min(u, kZeniths - 1 - 1e-9);
    const int i = static_cast<int>(u);
    const double f = u - i;
    return sky_[i] * (1.0 - f) + sky_[i + 1] * f;
}

double LwirTable::blackbody_W_m2_sr(double temperature_K) const {
    double u = (temperature_K - kMinTemperature_K) / kTemperatureStep_K;
    if (!(u > 0.0)) u = 0.0;
    u = std::min(u, kTemperatures - 1 - 1e-9);
    const int i = static_cast<int>(u);
    const double f = u - i;
    return planck_[i] * (1.0 - f) + planck_[i + 1] * f;
}

double LwirTable::brightnessTemperature_K(double radiance_W_m2_sr) const {
    // B_band rises with T: bisect the tabulated curve, then interpolate linearly.
    if (!(radiance_W_m2_sr > planck_.front())) return kMinTemperature_K;
    if (radiance_W_m2_sr >= planck_.back()) {
        return kMinTemperature_K + kTemperatureStep_K * (kTemperatures - 1);
    }
    const auto it = std::upper_bound(planck_.begin(), planck_.end(), radiance_W_m2_sr);
    const int i = static_cast<int>(it - planck_.begin()) - 1;
    const double f = (radiance_W_m2_sr - planck_[i]) / (planck_[i + 1] - planck_[i]);
    return kMinTemperature_K + kTemperatureStep_K * (i + f);
}

// ---- cache ----------------------------------------------------------------------------------

namespace {

void putVec(std::string* out, const std::vector<double>& v) {
    const std::uint64_t n = v.size();
    out->append(reinterpret_cast<const char*>(&n), sizeof n);
    out->append(reinterpret_cast<const char*>(v.data()), n * sizeof(double));
}

bool getVec(const std::string& in, std::size_t* pos, std::vector<double>* v, std::size_t expect) {
    std::uint64_t n = 0;
    if (*pos + sizeof n > in.size()) return false;
    std::memcpy(&n, in.data() + *pos, sizeof n);
    *pos += sizeof n;
    if (n != expect || *pos + n * sizeof(double) > in.size()) return false;
    v->resize(n);
    std::memcpy(v->data(), in.data() + *pos, n * sizeof(double));
    *pos += n * sizeof(double);
    return true;
}

}  // namespace

void LwirTable::save(const std::filesystem::path& file, std::uint64_t key) const {
    std::string payload;
    putVec(&payload, tau_);
    putVec(&payload, path_);
    putVec(&payload, sky_);
    putVec(&payload, planck_);
    putVec(&payload, tilted_);
    payload.append(reinterpret_cast<const char*>(&skyEmittance_), sizeof skyEmittance_);
    payload.append(reinterpret_cast<const char*>(&skyDiffuse_), sizeof skyDiffuse_);
    putVec(&payload, slantTau_);
    putVec(&payload, slantPath_);
    (void)writeTableFile(file, kFileFormat, key, payload);
}

bool LwirTable::load(const std::filesystem::path& file, std::uint64_t key, std::string* why) {
    std::string payload;
    if (!readTableFile(file, kFileFormat, key, &payload, why)) return false;
    LwirTable t;
    std::size_t pos = 0;
    if (!getVec(payload, &pos, &t.tau_, kRanges) || !getVec(payload, &pos, &t.path_, kRanges) ||
        !getVec(payload, &pos, &t.sky_, kZeniths) ||
        !getVec(payload, &pos, &t.planck_, kTemperatures) ||
        !getVec(payload, &pos, &t.tilted_, kTilts) || pos + 2 * sizeof(double) > payload.size()) {
        return (*why = "malformed payload", false);
    }
    std::memcpy(&t.skyEmittance_, payload.data() + pos, sizeof t.skyEmittance_);
    std::memcpy(&t.skyDiffuse_, payload.data() + pos + sizeof(double), sizeof t.skyDiffuse_);
    pos += 2 * sizeof(double);
    // The slant table is either absent or complete, the same size twice.
    const std::size_t nSlant = static_cast<std::size_t>(kSlantHeights) * kSlantZeniths * kRanges;
    std::uint64_t n = 0;
    if (pos + sizeof n > payload.size()) return (*why = "malformed payload", false);
    std::memcpy(&n, payload.data() + pos, sizeof n);
    const std::size_t expect = n == 0 ? 0 : nSlant;
    if (!getVec(payload, &pos, &t.slantTau_, expect) ||
        !getVec(payload, &pos, &t.slantPath_, expect) || pos != payload.size()) {
        return (*why = "malformed payload", false);
    }
    *this = std::move(t);
    return true;
}

LwirTable LwirTable::loadOrBuild(const LwirTableInputs& inputs, const DataDirs& dirs,
                                 bool* rebuilt) {
    validateAir(inputs.air);
    inputs.sky.validate();
    if (dirs.cache.empty()) {
        if (rebuilt != nullptr) *rebuilt = true;
        return build(inputs, dirs.config);
    }
    const std::uint64_t key = hashInputs(inputs, AbsorptionData::load(dirs.config));
    char name[40];
    std::snprintf(name, sizeof name, "lwir-%016llx.bin", static_cast<unsigned long long>(key));
    const auto file = dirs.cache / name;
    LwirTable t;
    std::string why;
    if (t.load(file, key, &why)) {
        if (rebuilt != nullptr) *rebuilt = false;
        return t;
    }
    if (why != "no cache file") {
        std::fprintf(stderr, "nvstim: LWIR cache %s unusable (%s); rebuilding\n", file.c_str(),
                     why.c_str());
    }
    t = build(inputs, dirs.config);
    t.save(file, key);
    if (rebuilt != nullptr) *rebuilt = true;
    return t;
}

}  // namespace nvs::lwir
