#include "sim/thermal/material.h"

#include <algorithm>
#include <cmath>
#include <complex>

#include "sim/core/config.h"
#include "sim/core/units.h"

namespace nvs::thermal {

double fresnelEmissivity(double n, double k, double cosTheta) noexcept {
    // Unpolarised Fresnel reflectance of a smooth interface, incidence from vacuum, with the
    // complex index N = n + ik (Siegel & Howell §3.5): with s = √(N² − sin²θ),
    //   r_s = (cos θ − s)/(cos θ + s),  r_p = (N² cos θ − s)/(N² cos θ + s),
    //   ε = 1 − (|r_s|² + |r_p|²)/2.
    const double c = std::clamp(cosTheta, 0.0, 1.0);
    const double sin2 = 1.0 - c * c;
    const std::complex<double> N(n, k);
    const std::complex<double> N2 = N * N;
    const std::complex<double> s = std::sqrt(N2 - sin2);
    const std::complex<double> rs = (c - s) / (c + s);
    const std::complex<double> rp = (N2 * c - s) / (N2 * c + s);
    return 1.0 - 0.5 * (std::norm(rs) + std::norm(rp));
}

double directionalEmissivity(const ThermalMaterial& m, double cosTheta) noexcept {
    switch (m.angular) {
        case AngularModel::Lambertian:
            return m.emissivityNormal;
        case AngularModel::Dielectric:
            return fresnelEmissivity(m.index_n, 0.0, cosTheta);
        case AngularModel::Metal:
            return fresnelEmissivity(m.index_n, m.index_n, cosTheta);
    }
    return m.emissivityNormal;
}

double hemisphericalEmissivity(const ThermalMaterial& m) {
    // ε_h = 2∫₀^{π/2} ε(θ) cos θ sin θ dθ = ∫₀^{π/2} ε(θ) sin 2θ dθ, composite Simpson.
    constexpr int kIntervals = 512;
    const double h = 0.5 * kPi / kIntervals;
    double sum = 0.0;
    for (int i = 0; i <= kIntervals; ++i) {
        const double th = i * h;
        const double w = (i == 0 || i == kIntervals) ? 1.0 : (i % 2 ? 4.0 : 2.0);
        sum += w * directionalEmissivity(m, std::cos(th)) * std::sin(2.0 * th);
    }
    return sum * h / 3.0;
}

namespace {

// The real index of a dielectric with normal emissivity ε_n: R = 1 − ε_n = ((n−1)/(n+1))².
double dielectricIndex(double eps) {
    const double r = std::sqrt(std::max(0.0, 1.0 - eps));
    return (1.0 + r) / (1.0 - r);
}

// n = k of a Hagen–Rubens metal with normal emissivity ε_n = 4n/((n+1)² + n²): by bisection
// on n ∈ [0.5, 1e6], where the function decreases monotonically (its maximum 0.83 lies at
// n = √2/2, so ε_n above that is not a metal).
double metalIndex(double eps) {
    auto f = [](double n) { return 4.0 * n / ((n + 1.0) * (n + 1.0) + n * n); };
    double lo = std::sqrt(0.5), hi = 1e6;
    for (int i = 0; i < 200; ++i) {
        const double mid = std::sqrt(lo * hi);
        (f(mid) > eps ? lo : hi) = mid;
    }
    return std::sqrt(lo * hi);
}

void fail(const ThermalMaterial& m, const std::string& what) {
    throw SetupError(m.loc, "material '" + m.name + "': " + what);
}

}  // namespace

void finishMaterial(ThermalMaterial& m) {
    if (!(m.emissivityNormal > 0.0 && m.emissivityNormal <= 1.0))
        fail(m, "emissivity outside (0, 1]");
    if (!(m.solarAbsorptance >= 0.0 && m.solarAbsorptance <= 1.0))
        fail(m, "solar absorptance outside [0, 1]");
    if (m.angular == AngularModel::Metal && m.emissivityNormal > 0.8)
        fail(m, "a metal's normal emissivity must be at most 0.8 (Hagen–Rubens fit)");
    m.index_n = m.angular == AngularModel::Metal ? metalIndex(m.emissivityNormal)
                                                 : dielectricIndex(m.emissivityNormal);
    m.emissivityHemispherical = hemisphericalEmissivity(m);
}

namespace {

AngularModel parseAngular(const ConfigTable& t) {
    const std::string s = t.get<std::string>("angular", "lambertian");
    if (s == "lambertian") return AngularModel::Lambertian;
    if (s == "dielectric") return AngularModel::Dielectric;
    if (s == "metal") return AngularModel::Metal;
    t.fail("angular", "unknown angular model '" + s + "' (lambertian, dielectric or metal)");
}

// Reads a number that must be positive (or ≥ 0 when allowZero), failing at its place.
double positive(const ConfigTable& t, std::string_view key, bool allowZero = false) {
    const double v = t.require<double>(key);
    if (!(allowZero ? v >= 0.0 : v > 0.0))
        t.fail(key, allowZero ? "must not be negative" : "must be positive");
    return v;
}

Layer readLayer(const ConfigTable& t) {
    Layer l;
    l.thickness_m = positive(t, "thickness_m");
    l.conductivity_W_mK = positive(t, "conductivity_W_mK");
    l.density_kg_m3 = positive(t, "density_kg_m3");
    l.specificHeat_J_kgK = positive(t, "specific_heat_J_kgK");
    return l;
}

void readBack(const ConfigTable& t, ThermalMaterial& m) {
    const std::string back = t.get<std::string>("back", "insulated");
    if (back == "insulated") {
        m.back = BackBoundary::Insulated;
    } else if (back == "fixed") {
        m.back = BackBoundary::FixedTemperature;
        m.backTemperature_K = positive(t, "back_temperature_K");
    } else if (back == "air") {
        m.back = BackBoundary::AirNode;
        m.backFilm_W_m2K = positive(t, "back_film_W_m2K");
        m.backFollowsAir = !t.contains("back_temperature_K");
        if (m.backFollowsAir)
            m.backAirOffset_K = t.get<double>("back_air_offset_K", 0.0);
        else
            m.backTemperature_K = positive(t, "back_temperature_K");
    } else {
        t.fail("back", "unknown back boundary '" + back + "' (insulated, fixed or air)");
    }
    if (t.contains("back_flux_W_m2")) {
        if (m.back == BackBoundary::FixedTemperature)
            t.fail("back_flux_W_m2", "a fixed-temperature back takes no flux");
        m.backFlux_W_m2 = t.require<double>("back_flux_W_m2");
    }
}

ThermalMaterial readMaterial(const ConfigTable& root, const std::string& name) {
    const ConfigTable t = root.table(name);
    ThermalMaterial m;
    m.name = name;
    m.loc = root.location(name);
    if (t.require<std::string>("source").empty()) t.fail("source", "empty source");
    m.emissivityNormal = t.require<double>("emissivity");
    if (!(m.emissivityNormal > 0.0 && m.emissivityNormal <= 1.0))
        t.fail("emissivity", "emissivity outside (0, 1]");
    m.angular = parseAngular(t);
    m.solarAbsorptance = t.get<double>("solar_absorptance", m.solarAbsorptance);
    if (!(m.solarAbsorptance >= 0.0 && m.solarAbsorptance <= 1.0))
        t.fail("solar_absorptance", "outside [0, 1]");
    m.roughnessMultiplier = t.get<double>("roughness", 1.0);
    if (!(m.roughnessMultiplier >= 1.0 && m.roughnessMultiplier <= 2.5))
        t.fail("roughness", "DOE-2 roughness multiplier outside [1, 2.5]");
    if (t.contains("surface_temperature_K")) {
        m.surfaceTemperature_K = positive(t, "surface_temperature_K");
        if (t.contains("layer")) t.fail("layer", "a fixed-temperature surface takes no layers");
    }
    m.collectsDew = t.get<bool>("dew", true);
    if (t.contains("surface_resistance_day_s_m") || t.contains("surface_resistance_night_s_m")) {
        m.surfaceResistanceDay_s_m = positive(t, "surface_resistance_day_s_m");
        m.surfaceResistanceNight_s_m = positive(t, "surface_resistance_night_s_m");
    }
    for (const ConfigTable& l : t.tableArray("layer"))
        m.layers.push_back(readLayer(l));
    if (!m.layers.empty()) readBack(t, m);
    finishMaterial(m);
    return m;
}

MaterialLibrary fromDocument(const ConfigDocument& doc) {
    const ConfigTable root = doc.root();
    MaterialLibrary lib;
    std::vector<ThermalMaterial> ms;
    for (const std::string& key : root.keys()) {
        if (key == "source") continue;
        ms.push_back(readMaterial(root, key));
    }
    const std::string source = root.require<std::string>("source");
    doc.finish();
    return MaterialLibrary::fromList(std::move(ms), source);
}

}  // namespace

MaterialLibrary MaterialLibrary::fromList(std::vector<ThermalMaterial> ms, std::string source) {
    MaterialLibrary lib;
    lib.materials_ = std::move(ms);
    lib.source_ = std::move(source);
    return lib;
}

MaterialLibrary MaterialLibrary::load(const std::filesystem::path& path) {
    return fromDocument(ConfigDocument::parseFile(path));
}

MaterialLibrary MaterialLibrary::parse(std::string_view text, const std::string& name) {
    return fromDocument(ConfigDocument::parseString(text, name));
}

const ThermalMaterial& MaterialLibrary::get(std::string_view name, const FileLoc& askedAt) const {
    for (const ThermalMaterial& m : materials_)
        if (m.name == name) return m;
    throw SetupError(askedAt, "no thermal material '" + std::string(name) + "'");
}

const ThermalMaterial& MaterialLibrary::requireThermal(std::string_view name,
                                                       const FileLoc& askedAt) const {
    const ThermalMaterial& m = get(name, askedAt);
    if (!m.hasThermal())
        throw SetupError(askedAt,
                         "material '" + m.name + "' (" + m.loc.str() + ") has no thermal layers");
    return m;
}

}  // namespace nvs::thermal
