#include "sim/sky/atmosphere_table.h"

#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>

#include "sim/core/fnv.h"
#include "sim/core/table_file.h"
#include "sim/core/units.h"

namespace nvs::sky {
namespace {

constexpr double kSourceStep_deg = 2.0;
constexpr double kViewStep_deg = 2.0;
constexpr double kAzimuthStep_deg = 5.0;
constexpr double kDirectStep_deg = 0.25;
constexpr float kLogFloor = -80.0f;
constexpr double kAirglowHeight_km = 97.0;  // OI 557.7 nm / OH layer, van Rhijn (1921)
constexpr double kEarthRadius_km = 6371.0;
constexpr char kMagic[8] = {'N', 'V', 'S', 'A', 'T', 'M', 'T', 'B'};
// The cache file (sim/core/table_file.h); its checksum keeps this table's own FNV basis.
constexpr TableFileFormat kFileFormat{kMagic, AtmosphereTable::kFormatVersion,
                                      1469598103934665603ull, "atmosphere"};

// The cache key and payload checksum hash (sim/core/fnv.h) with this table's offset basis.
struct Fnv : Fnv1a {
    Fnv() : Fnv1a(1469598103934665603ull) {}
    void f64(double v) { bytes(&v, sizeof v); }
    void str(const std::string& s) {
        bytes(s.data(), s.size());
        bytes("\0", 1);
    }
    void spectrum(const Spectrum& s) {
        bytes(s.values().data(), sizeof(double) * s.values().size());
    }
};

std::uint64_t hashInputs(const AtmosphereTableInputs& in) {
    Fnv f;
    const std::uint32_t v = AtmosphereTable::kFormatVersion;
    f.bytes(&v, sizeof v);
    const AtmosphereParams& a = in.atmosphere;
    for (double x :
         {a.siteAltitude_m, a.visibility_km, a.aerosolScaleHeight_m, a.ozone_DU,
          a.precipitableWater_cm, a.cloudOpticalDepth, a.cloudAsymmetry, a.groundAlbedo}) {
        f.f64(x);
    }
    f.str(aerosolModelName(a.aerosol));
    f.spectrum(in.sourceShape);
    f.spectrum(in.nightSky.airglowRadiance_W_m2_sr_nm);
    f.spectrum(in.nightSky.continuumRadiance_W_m2_sr_nm);
    for (const SkyBand& b : in.bands) {
        f.str(b.name);
        f.spectrum(b.weight);
    }
    return f.h;
}

// Linear interpolation position on a uniform grid, clamped: index i and fraction t.
inline void gridPos(double x, double step, int n, int* i, double* t) {
    double u = x / step;
    if (u <= 0.0) u = 0.0;
    if (u >= n - 1) u = n - 1 - 1e-9;
    *i = static_cast<int>(u);
    *t = u - *i;
}

inline double lerp(float a, float b, double t) {
    return static_cast<double>(a) * (1.0 - t) + static_cast<double>(b) * t;
}

// van Rhijn factor: slant path through a thin emitting layer at height h relative to the
// vertical one, 1/√(1 − (R/(R+h))² sin²z).
double vanRhijn(double zenith_rad) {
    const double r = kEarthRadius_km / (kEarthRadius_km + kAirglowHeight_km);
    const double s = std::sin(zenith_rad);
    return 1.0 / std::sqrt(1.0 - r * r * s * s);
}

}  // namespace

std::string AtmosphereTable::cacheKey(const AtmosphereTableInputs& inputs) {
    char buf[17];
    std::snprintf(buf, sizeof buf, "%016llx", static_cast<unsigned long long>(hashInputs(inputs)));
    return buf;
}

int AtmosphereTable::bandIndex(const std::string& name) const {
    for (int b = 0; b < bandCount(); ++b) {
        if (bandNames_[b] == name) return b;
    }
    return -1;
}

AtmosphereTable AtmosphereTable::build(const AtmosphereTableInputs& in,
                                       const std::filesystem::path& configDir) {
    if (in.bands.empty()) throw SetupError("atmosphere table: no bands given");
    const Atmosphere atm(in.atmosphere, configDir);
    const int nb = static_cast<int>(in.bands.size());
    AtmosphereTable t;
    for (const SkyBand& b : in.bands) {
        t.bandNames_.push_back(b.name);
        const double s = integrateProduct_nm(in.sourceShape, b.weight);
        if (!(s > 0.0)) {
            throw SetupError("atmosphere table: the source spectrum has no energy in band '" +
                             b.name + "'");
        }
        t.sourceBand_.push_back(s);
    }
    // Band weights premultiplied by the source shape: a band term is ∫(E0·w)·X / ∫E0·w.
    std::vector<Spectrum> sw(nb);
    for (int b = 0; b < nb; ++b)
        sw[b] = in.sourceShape * in.bands[b].weight * (1.0 / t.sourceBand_[b]);

    t.logDirect_.assign(static_cast<std::size_t>(nb) * kDirectZeniths, kLogFloor);
    for (int i = 0; i < kDirectZeniths; ++i) {
        const Spectrum tr = atm.directTransmittance(i * kDirectStep_deg * kRadPerDeg);
        for (int b = 0; b < nb; ++b) {
            const double v = integrateProduct_nm(tr, sw[b]);
            t.logDirect_[static_cast<std::size_t>(b) * kDirectZeniths + i] =
                v > 0.0 ? std::max(kLogFloor, static_cast<float>(std::log(v))) : kLogFloor;
        }
    }

    for (int b = 0; b < nb; ++b) {
        t.bandTau_.push_back(integrateProduct_nm(atm.rayleighTau(), sw[b]));
        t.bandTau_.push_back(integrateProduct_nm(atm.aerosolTau(), sw[b]));
    }
    const AerosolOptics ao = aerosolOptics(in.atmosphere.aerosol);
    t.scalars_ = {in.atmosphere.aerosolScaleHeight_m, ao.singleScatteringAlbedo, ao.asymmetry,
                  in.atmosphere.groundAlbedo};

    t.diffuse_.assign(static_cast<std::size_t>(nb) * kSourceZeniths, 0.0f);
    t.sky_.assign(static_cast<std::size_t>(nb) * kSourceZeniths * kViewZeniths * kAzimuths, 0.0f);
    Spectrum iso, l;
    for (int is = 0; is < kSourceZeniths; ++is) {
        const double zs = is * kSourceStep_deg * kRadPerDeg;
        atm.isotropicRadiancePerIrradiance(zs, &iso);
        const Spectrum dif = atm.singleScatterHorizontalPerIrradiance(zs) + iso * kPi;
        std::vector<double> isoBand(nb);
        for (int b = 0; b < nb; ++b) {
            t.diffuse_[static_cast<std::size_t>(b) * kSourceZeniths + is] =
                static_cast<float>(integrateProduct_nm(dif, sw[b]));
            isoBand[b] = integrateProduct_nm(iso, sw[b]);
        }
        for (int iv = 0; iv < kViewZeniths; ++iv) {
            // The last row sits just above the horizon so the single-scattering path stays finite.
            const double zv = std::min(iv * kViewStep_deg, 89.9) * kRadPerDeg;
            for (int ia = 0; ia < kAzimuths; ++ia) {
                const double dphi = ia * kAzimuthStep_deg * kRadPerDeg;
                const double cosPsi =
                    std::cos(zv) * std::cos(zs) + std::sin(zv) * std::sin(zs) * std::cos(dphi);
                atm.singleScatterRadiancePerIrradiance(zv, zs, cosPsi, &l);
                for (int b = 0; b < nb; ++b) {
                    t.sky_[t.skyIndex(b, is, iv, ia)] =
                        static_cast<float>(integrateProduct_nm(l, sw[b]) + isoBand[b]);
                }
            }
        }
    }

    // Night sky: airglow ∝ van Rhijn × extinction, renormalised to keep its horizontal
    // irradiance; continuum isotropic; both through the cloud.
    t.night_.assign(static_cast<std::size_t>(nb) * kViewZeniths, 0.0f);
    t.nightHorizontal_.assign(nb, 0.0);
    const double cloudT = atm.cloudIsotropicTransmittance();
    Spectrum tauExt = atm.rayleighTau() + atm.aerosolTau() + atm.absorptionTau();
    // Shape per λ at each view zenith, and its cosine-weighted hemispheric integral.
    std::vector<Spectrum> shape(kViewZeniths);
    Spectrum norm;
    for (int iv = 0; iv < kViewZeniths; ++iv) {
        const double zv = std::min(iv * kViewStep_deg, 89.9) * kRadPerDeg;
        const double m = airmassKastenYoung(zv);
        const double vr = vanRhijn(zv);
        for (int i = 0; i < Spectrum::size(); ++i) {
            shape[iv][i] = vr * std::exp(-tauExt[i] * (m - 1.0));
        }
    }
    // ∫ shape cosθ dΩ = 2π ∫ shape(θ) cosθ sinθ dθ, trapezoid on the 2° grid (to 90°).
    for (int iv = 0; iv < kViewZeniths; ++iv) {
        const double zv = iv * kViewStep_deg * kRadPerDeg;
        const double w =
            ((iv == 0 || iv == kViewZeniths - 1) ? 0.5 : 1.0) * kViewStep_deg * kRadPerDeg;
        norm += shape[iv] * (2.0 * kPi * std::cos(zv) * std::sin(zv) * w);
    }
    for (int b = 0; b < nb; ++b) {
        const Spectrum& w = in.bands[b].weight;
        const double cont = integrateProduct_nm(in.nightSky.continuumRadiance_W_m2_sr_nm, w);
        for (int iv = 0; iv < kViewZeniths; ++iv) {
            double ag = 0.0;
            for (int i = 0; i < Spectrum::size(); ++i) {
                if (norm[i] > 0.0) {
                    ag += in.nightSky.airglowRadiance_W_m2_sr_nm[i] * kPi * shape[iv][i] / norm[i] *
                          w[i];
                }
            }
            t.night_[static_cast<std::size_t>(b) * kViewZeniths + iv] =
                static_cast<float>((ag * SpectralGrid::kStep_nm + cont) * cloudT);
        }
        const double ag = integrateProduct_nm(in.nightSky.airglowRadiance_W_m2_sr_nm, w);
        t.nightHorizontal_[b] = kPi * (ag + cont) * cloudT;
    }
    return t;
}

double AtmosphereTable::directTransmittance(int b, double sourceZenith_rad) const {
    const double z_deg = sourceZenith_rad * kDegPerRad;
    if (z_deg >= 96.0) return 0.0;
    int i = 0;
    double f = 0.0;
    gridPos(std::max(0.0, z_deg), kDirectStep_deg, kDirectZeniths, &i, &f);
    const float* d = &logDirect_[static_cast<std::size_t>(b) * kDirectZeniths];
    return std::exp(lerp(d[i], d[i + 1], f));
}

double AtmosphereTable::diffuseHorizontal(int b, double sourceZenith_rad) const {
    const double z_deg = sourceZenith_rad * kDegPerRad;
    if (z_deg >= 96.0) return 0.0;
    int i = 0;
    double f = 0.0;
    gridPos(std::max(0.0, z_deg), kSourceStep_deg, kSourceZeniths, &i, &f);
    const float* d = &diffuse_[static_cast<std::size_t>(b) * kSourceZeniths];
    return lerp(d[i], d[i + 1], f);
}

double AtmosphereTable::skyRadiance(int b, double viewZenith_rad, double relAzimuth_rad,
                                    double sourceZenith_rad) const {
    const double zs_deg = sourceZenith_rad * kDegPerRad;
    if (zs_deg >= 96.0) return 0.0;
    double dphi_deg = std::fabs(std::remainder(relAzimuth_rad, kTwoPi)) * kDegPerRad;
    int is = 0, iv = 0, ia = 0;
    double fs = 0.0, fv = 0.0, fa = 0.0;
    gridPos(std::max(0.0, zs_deg), kSourceStep_deg, kSourceZeniths, &is, &fs);
    gridPos(std::clamp(viewZenith_rad * kDegPerRad, 0.0, 90.0), kViewStep_deg, kViewZeniths, &iv,
            &fv);
    gridPos(dphi_deg, kAzimuthStep_deg, kAzimuths, &ia, &fa);
    double v = 0.0;
    for (int ds = 0; ds < 2; ++ds) {
        const double ws = ds ? fs : 1.0 - fs;
        for (int dv = 0; dv < 2; ++dv) {
            const double wv = dv ? fv : 1.0 - fv;
            const float* row = &sky_[skyIndex(b, is + ds, iv + dv, ia)];
            v += ws * wv * lerp(row[0], row[1], fa);
        }
    }
    return v;
}

double AtmosphereTable::nightSkyRadiance(int b, double viewZenith_rad) const {
    int i = 0;
    double f = 0.0;
    gridPos(std::clamp(viewZenith_rad * kDegPerRad, 0.0, 90.0), kViewStep_deg, kViewZeniths, &i,
            &f);
    const float* d = &night_[static_cast<std::size_t>(b) * kViewZeniths];
    return lerp(d[i], d[i + 1], f);
}

PathTerms AtmosphereTable::path(int b, double sensorHeight_m, double viewZenith_rad, double range_m,
                                double cosScatter, double sourceZenith_rad) const {
    // Gauss–Legendre, 16 points on [0, 1].
    static constexpr double kX[16] = {
        0.0052995325041750, 0.0277124884633837, 0.0671843988060841, 0.1222977958224985,
        0.1910618777986781, 0.2709916111713863, 0.3591982246103705, 0.4524937450811813,
        0.5475062549188188, 0.6408017753896295, 0.7290083888286137, 0.8089381222013219,
        0.8777022041775016, 0.9328156011939159, 0.9722875115366163, 0.9947004674958250};
    static constexpr double kW[16] = {
        0.0135762297058770, 0.0311267619693240, 0.0475792558412464, 0.0623144856277669,
        0.0747979944082884, 0.0845782596975013, 0.0913017075224618, 0.0947253052275342,
        0.0947253052275342, 0.0913017075224618, 0.0845782596975013, 0.0747979944082884,
        0.0623144856277669, 0.0475792558412464, 0.0311267619693240, 0.0135762297058770};
    constexpr double kHr = 8434.5;
    PathTerms out;
    if (!(range_m > 0.0)) return out;
    const double tauR = bandTau_[2 * static_cast<std::size_t>(b)];
    const double tauA = bandTau_[2 * static_cast<std::size_t>(b) + 1];
    const double ha = scalars_[0], omegaA = scalars_[1], g = scalars_[2], rho = scalars_[3];
    const double mu = std::cos(viewZenith_rad);
    const double h0 = std::max(0.0, sensorHeight_m);
    // Optical depth from the sensor to distance s for a layer τ_c e^{−h/H_c}/H_c.
    const auto depth = [&](double tauC, double hc, double s) {
        const double a = std::exp(-h0 / hc) * tauC / hc;
        if (std::fabs(mu) * s < 1e-6 * hc) return a * s;
        return a * hc / mu * (1.0 - std::exp(-mu * s / hc));
    };
    const double pR = rayleighPhase(cosScatter);
    const double pA = henyeyGreensteinPhase(cosScatter, g);
    const bool sourceUp = sourceZenith_rad * kDegPerRad < 96.0;
    const double tDir = sourceUp ? directTransmittance(b, sourceZenith_rad) : 0.0;
    const double ms = airmassKastenYoung(sourceZenith_rad);
    const double eDif = sourceUp ? diffuseHorizontal(b, sourceZenith_rad) : 0.0;
    const double eTot = tDir * std::max(0.0, std::cos(sourceZenith_rad)) + eDif;
    const double diffuseIn = (eDif + rho * eTot) / (2.0 * kPi);
    const double nightIn = nightHorizontal_[b] * (1.0 + rho) / (2.0 * kPi);
    for (int k = 0; k < 16; ++k) {
        const double s = kX[k] * range_m;
        const double h = std::max(0.0, h0 + mu * s);
        const double bR = tauR / kHr * std::exp(-h / kHr);
        const double bA = tauA / ha * std::exp(-h / ha);
        const double tr = std::exp(-(depth(tauR, kHr, s) + depth(tauA, ha, s)));
        // The beam at height h has crossed less air than at the ground.
        const double beam = sourceUp ? tDir * std::exp(ms * (tauR * (1.0 - std::exp(-h / kHr)) +
                                                             tauA * (1.0 - std::exp(-h / ha))))
                                     : 0.0;
        const double bSca = bR + omegaA * bA;
        const double j = (bR * pR + omegaA * bA * pA) * beam / (4.0 * kPi) + bSca * diffuseIn;
        out.radiancePerIrradiance += kW[k] * range_m * j * tr;
        out.nightSkyRadiance += kW[k] * range_m * bSca * nightIn * tr;
    }
    out.transmittance = std::exp(-(depth(tauR, kHr, range_m) + depth(tauA, ha, range_m)));
    return out;
}

// ---- cache -------------------------------------------------------------------------------

namespace {

template <typename T>
void putVec(std::string* out, const std::vector<T>& v) {
    const std::uint64_t n = v.size();
    out->append(reinterpret_cast<const char*>(&n), sizeof n);
    out->append(reinterpret_cast<const char*>(v.data()), n * sizeof(T));
}

template <typename T>
bool getVec(const std::string& in, std::size_t* pos, std::vector<T>* v, std::size_t expect) {
    std::uint64_t n = 0;
    if (*pos + sizeof n > in.size()) return false;
    std::memcpy(&n, in.data() + *pos, sizeof n);
    *pos += sizeof n;
    if (n != expect || *pos + n * sizeof(T) > in.size()) return false;
    v->resize(n);
    std::memcpy(v->data(), in.data() + *pos, n * sizeof(T));
    *pos += n * sizeof(T);
    return true;
}

}  // namespace

void AtmosphereTable::save(const std::filesystem::path& file, std::uint64_t key) const {
    std::string payload;
    const std::uint32_t nb = static_cast<std::uint32_t>(bandCount());
    payload.append(reinterpret_cast<const char*>(&nb), sizeof nb);
    for (const auto& n : bandNames_) {
        const std::uint32_t len = static_cast<std::uint32_t>(n.size());
        payload.append(reinterpret_cast<const char*>(&len), sizeof len);
        payload.append(n);
    }
    putVec(&payload, sourceBand_);
    putVec(&payload, logDirect_);
    putVec(&payload, diffuse_);
    putVec(&payload, sky_);
    putVec(&payload, night_);
    putVec(&payload, nightHorizontal_);
    putVec(&payload, bandTau_);
    putVec(&payload, scalars_);
    (void)writeTableFile(file, kFileFormat, key, payload);
}

bool AtmosphereTable::load(const std::filesystem::path& file, std::uint64_t key, int bandCount,
                           std::string* why) {
    std::string payload;
    if (!readTableFile(file, kFileFormat, key, &payload, why)) return false;
    std::size_t pos = 0;
    std::uint32_t nb = 0;
    std::memcpy(&nb, payload.data(), sizeof nb);
    pos += sizeof nb;
    if (static_cast<int>(nb) != bandCount) {
        *why = "band count mismatch";
        return false;
    }
    AtmosphereTable t;
    for (std::uint32_t b = 0; b < nb; ++b) {
        std::uint32_t len = 0;
        if (pos + sizeof len > payload.size()) return (*why = "truncated", false);
        std::memcpy(&len, payload.data() + pos, sizeof len);
        pos += sizeof len;
        if (pos + len > payload.size()) return (*why = "truncated", false);
        t.bandNames_.push_back(payload.substr(pos, len));
        pos += len;
    }
    const std::size_t n = nb;
    if (!getVec(payload, &pos, &t.sourceBand_, n) ||
        !getVec(payload, &pos, &t.logDirect_, n * kDirectZeniths) ||
        !getVec(payload, &pos, &t.diffuse_, n * kSourceZeniths) ||
        !getVec(payload, &pos, &t.sky_, n * kSourceZeniths * kViewZeniths * kAzimuths) ||
        !getVec(payload, &pos, &t.night_, n * kViewZeniths) ||
        !getVec(payload, &pos, &t.nightHorizontal_, n) ||
        !getVec(payload, &pos, &t.bandTau_, 2 * n) || !getVec(payload, &pos, &t.scalars_, 4) ||
        pos != payload.size()) {
        *why = "malformed payload";
        return false;
    }
    *this = std::move(t);
    return true;
}

AtmosphereTable AtmosphereTable::loadOrBuild(const AtmosphereTableInputs& inputs,
                                             const DataDirs& dirs, bool* rebuilt) {
    inputs.atmosphere.validate();
    if (dirs.cache.empty()) {
        if (rebuilt != nullptr) *rebuilt = true;
        return build(inputs, dirs.config);
    }
    const std::uint64_t key = hashInputs(inputs);
    const auto file = dirs.cache / ("atmosphere-" + cacheKey(inputs) + ".bin");
    AtmosphereTable t;
    std::string why;
    if (t.load(file, key, static_cast<int>(inputs.bands.size()), &why)) {
        if (rebuilt != nullptr) *rebuilt = false;
        return t;
    }
    if (why != "no cache file") {
        std::fprintf(stderr, "nvstim: atmosphere cache %s unusable (%s); rebuilding\n",
                     file.c_str(), why.c_str());
    }
    t = build(inputs, dirs.config);
    t.save(file, key);
    if (rebuilt != nullptr) *rebuilt = true;
    return t;
}

}  // namespace nvs::sky
