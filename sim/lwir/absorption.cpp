#include "sim/lwir/absorption.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/core/csv.h"
#include "sim/core/error.h"
#include "sim/core/fnv.h"
#include "sim/lwir/humidity.h"

namespace nvs::lwir {
namespace {

constexpr double kRwT0_K = 260.0;  // Rodgers & Walshaw's reference temperature

// The file's source line must be present: every data file names its source.
void requireSource(const CsvTable& t) {
    if (t.commentValue("source").empty() && t.commentValue("source (co2)").empty()) {
        throw SetupError(t.headerLoc(), "coefficient file names no '# source:'");
    }
}

double positive(const CsvTable& t, std::size_t row, std::size_t col) {
    const double v = t.number(row, col);
    if (!(v > 0.0)) {
        throw SetupError(t.rowLoc(row),
                         "'" + t.header()[col] + "' must be positive, got " + t.row(row)[col]);
    }
    return v;
}

ContinuumCoefficients loadContinuum(const std::filesystem::path& file) {
    const CsvTable t = CsvTable::load(file);
    requireSource(t);
    const std::size_t cName = t.column("name"), cValue = t.column("value");
    ContinuumCoefficients c;
    struct Key {
        const char* name;
        double* value;
        bool seen;
    };
    Key keys[] = {{"a", &c.a_cm2_atm, false},  {"b", &c.b_cm2_atm, false},
                  {"beta", &c.beta_cm, false}, {"t_ref", &c.tRef_K, false},
                  {"t0", &c.t0_K, false},      {"gamma", &c.gamma, false}};
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        bool known = false;
        for (Key& k : keys) {
            if (t.row(r)[cName] != k.name) continue;
            if (k.seen) throw SetupError(t.rowLoc(r), std::string("'") + k.name + "' repeated");
            *k.value = positive(t, r, cValue);
            k.seen = known = true;
        }
        if (!known) throw SetupError(t.rowLoc(r), "unknown coefficient '" + t.row(r)[cName] + "'");
    }
    for (const Key& k : keys) {
        if (!k.seen)
            throw SetupError(t.headerLoc(), std::string("no coefficient '") + k.name + "'");
    }
    return c;
}

std::vector<LineInterval> loadLines(const std::filesystem::path& file) {
    const CsvTable t = CsvTable::load(file);
    requireSource(t);
    const std::size_t cLo = t.column("lo_cm-1"), cHi = t.column("hi_cm-1"),
                      cK = t.column("k_over_delta_cm2_g"), cY = t.column("pi_alpha0_over_delta"),
                      cA = t.column("a_per_K"), cB = t.column("b_per_K2");
    std::vector<LineInterval> out;
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        LineInterval l;
        l.lo_cm1 = positive(t, r, cLo);
        l.hi_cm1 = positive(t, r, cHi);
        if (l.hi_cm1 <= l.lo_cm1 || (!out.empty() && l.lo_cm1 < out.back().hi_cm1)) {
            throw SetupError(t.rowLoc(r), "intervals must be non-empty and in increasing order");
        }
        l.kOverDelta_cm2_g = positive(t, r, cK);
        l.piAlphaOverDelta = positive(t, r, cY);
        l.a_per_K = t.number(r, cA);
        l.b_per_K2 = t.number(r, cB);
        out.push_back(l);
    }
    if (out.empty()) throw SetupError(t.headerLoc(), "no intervals");
    return out;
}

void loadBands(const std::filesystem::path& file, ExponentialBand* co2, ExponentialBand* o3) {
    const CsvTable t = CsvTable::load(file);
    requireSource(t);
    const std::size_t cName = t.column("absorber");
    const char* cols[] = {"center_cm-1", "alpha_cm-1_per_g_m-2",
                          "omega0_cm-1", "t_omega_K",
                          "beta0",       "t_beta_K",
                          "n",           "b"};
    bool seenCo2 = false, seenO3 = false;
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        const std::string& name = t.row(r)[cName];
        ExponentialBand* b = name == "co2" ? co2 : name == "o3" ? o3 : nullptr;
        if (b == nullptr) throw SetupError(t.rowLoc(r), "unknown absorber '" + name + "'");
        bool& seen = name == "co2" ? seenCo2 : seenO3;
        if (seen) throw SetupError(t.rowLoc(r), "absorber '" + name + "' repeated");
        seen = true;
        double* fields[] = {&b->center_cm1, &b->alpha_cm1_per_g_m2,
                            &b->omega0_cm1, &b->tOmega_K,
                            &b->beta0,      &b->tBeta_K,
                            &b->n,          &b->b};
        for (int k = 0; k < 8; ++k)
            *fields[k] = positive(t, r, t.column(cols[k]));
    }
    if (!seenCo2 || !seenO3) throw SetupError(t.headerLoc(), "needs rows 'co2' and 'o3'");
}

// Goody random model: t = exp(−W / √(1 + W/y)).
inline double goody(double w, double wy) {
    if (!(w > 0.0)) return 1.0;
    const double y = wy / w;
    return std::exp(-w / std::sqrt(1.0 + w / y));
}

}  // namespace

AbsorptionData AbsorptionData::load(const std::filesystem::path& configDir) {
    const auto dir = configDir / "lwir";
    AbsorptionData d;
    d.continuum = loadContinuum(dir / "h2o_continuum_roberts1976.csv");
    d.h2oLines = loadLines(dir / "h2o_lines_rodgers_walshaw1966.csv");
    loadBands(dir / "band_models_co2_o3.csv", &d.co2, &d.o3);
    return d;
}

std::uint64_t AbsorptionData::hash() const {
    Fnv1a f;
    f.bytes(&continuum, sizeof continuum);
    for (const LineInterval& l : h2oLines)
        f.bytes(&l, sizeof l);
    f.bytes(&co2, sizeof co2);
    f.bytes(&o3, sizeof o3);
    return f.h;
}

PathAbsorption::PathAbsorption(const AbsorptionData& data) : data_(&data) {
    const ContinuumCoefficients& c = data.continuum;
    for (int i = 0; i < Grid::kSize; ++i) {
        const double nu = Grid::wavenumber_cm1(i);
        continuumBase_cm2_atm_[i] = c.a_cm2_atm + c.b_cm2_atm * std::exp(-c.beta_cm * nu);
        for (const LineInterval& l : data.h2oLines) {
            if (nu >= l.lo_cm1 && nu < l.hi_cm1) {
                h2oK_[i] = l.kOverDelta_cm2_g;
                h2oY_[i] = l.piAlphaOverDelta;
                h2oA_[i] = l.a_per_K;
                h2oB_[i] = l.b_per_K2;
            }
        }
    }
}

void PathAbsorption::reset() {
    continuumDepth_.fill(0.0);
    for (auto& s : w_)
        s.fill(0.0);
    for (auto& s : wy_)
        s.fill(0.0);
}

void PathAbsorption::add(const AirState& s, double length_m) {
    if (!(length_m > 0.0)) return;
    const double t = s.temperature_K, p = s.pressure_Pa, e = s.vapourPressure_Pa;
    const double pAtm = p / kStandardPressure_Pa;
    // Water column: molecules cm⁻² and g cm⁻² (1 kg m⁻² = 0.1 g cm⁻²).
    const double water_kg_m2 = vapourDensity_kg_m3(e, t) * length_m;
    const double water_g_cm2 = 0.1 * water_kg_m2;
    const double water_molec_cm2 = water_g_cm2 / (kMolarMassWater_kg_mol * 1e3) * kAvogadro_mol;
    // Continuum: k = C_s(ν) exp[T0 (1/T − 1/T_ref)] (e + γ (P − e)) [atm].
    const ContinuumCoefficients& c = data_->continuum;
    const double broadening_atm = (e + c.gamma * (p - e)) / kStandardPressure_Pa;
    const double cont =
        std::exp(c.t0_K * (1.0 / t - 1.0 / c.tRef_K)) * broadening_atm * water_molec_cm2;
    // Rodgers & Walshaw: y = πα0/δ · p/p0, S/S0 = exp[a ΔT + b ΔT²].
    const double dT = t - kRwT0_K;
    // Column densities [g m⁻²] of the well-mixed CO2 and of O3: x p M / (R T) · L.
    const double airMol_m3 = p / (kGasConstant_J_mol_K * t);
    const double co2_g_m2 = s.co2_ppm * 1e-6 * airMol_m3 * kMolarMassCo2_kg_mol * 1e3 * length_m;
    const double o3_g_m2 = s.o3_ppb * 1e-9 * airMol_m3 * kMolarMassO3_kg_mol * 1e3 * length_m;
    const ExponentialBand* bands[2] = {&data_->co2, &data_->o3};
    const double amounts[2] = {co2_g_m2, o3_g_m2};
    const double fractions[2] = {s.co2_ppm * 1e-6, s.o3_ppb * 1e-9};
    double omega[2], y[2];
    for (int k = 0; k < 2; ++k) {
        const ExponentialBand& b = *bands[k];
        omega[k] = b.omega0_cm1 * std::sqrt(t / b.tOmega_K);
        const double pe = pAtm * (1.0 + (b.b - 1.0) * fractions[k]);
        y[k] = b.beta0 * std::sqrt(b.tBeta_K / t) * std::pow(pe, b.n);
    }
    for (int i = lo_; i <= hi_; ++i) {
        continuumDepth_[i] += continuumBase_cm2_atm_[i] * cont;
        if (h2oK_[i] > 0.0) {
            const double w = h2oK_[i] * std::exp(h2oA_[i] * dT + h2oB_[i] * dT * dT) * water_g_cm2;
            w_[0][i] += w;
            wy_[0][i] += w * h2oY_[i] * pAtm;
        }
        const double nu = Grid::wavenumber_cm1(i);
        for (int k = 0; k < 2; ++k) {
            const ExponentialBand& b = *bands[k];
            const double sd = b.alpha_cm1_per_g_m2 / omega[k] *
                              std::exp(-2.0 * std::fabs(nu - b.center_cm1) / omega[k]);
            const double w = sd * amounts[k];
            w_[k + 1][i] += w;
            wy_[k + 1][i] += w * y[k];
        }
    }
}

void PathAbsorption::setActive(int lo, int hi) {
    lo_ = std::max(0, lo);
    hi_ = std::min(Grid::kSize - 1, hi);
}

double PathAbsorption::transmittance(int i) const {
    double tr = std::exp(-continuumDepth_[i]);
    for (int k = 0; k < kLineAbsorbers; ++k)
        tr *= goody(w_[k][i], wy_[k][i]);
    return tr;
}

Spectral homogeneousTransmittance(const AbsorptionData& data, const AirState& air, double range_m) {
    if (!(range_m >= 0.0)) {
        throw SetupError("lwir: path length " + std::to_string(range_m) + " m is negative");
    }
    if (!(air.vapourPressure_Pa >= 0.0)) {
        throw SetupError("lwir: water vapour pressure " + std::to_string(air.vapourPressure_Pa) +
                         " Pa is negative");
    }
    PathAbsorption p(data);
    p.reset();
    p.add(air, range_m);
    Spectral out{};
    for (int i = 0; i < Grid::kSize; ++i)
        out[i] = p.transmittance(i);
    return out;
}

}  // namespace nvs::lwir
