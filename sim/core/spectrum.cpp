#include "sim/core/spectrum.h"

#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "sim/core/csv.h"

namespace nvs {

double Spectrum::at_nm(double wavelength_nm) const {
    const double x = (wavelength_nm - SpectralGrid::kMin_nm) / SpectralGrid::kStep_nm;
    if (x < 0.0 || x > SpectralGrid::kCount - 1) return 0.0;
    const int i = std::min(static_cast<int>(x), SpectralGrid::kCount - 2);
    const double t = x - i;
    return v_[i] * (1.0 - t) + v_[i + 1] * t;
}

double Spectrum::integrate_nm() const {
    double sum = 0.0;
    for (double x : v_)
        sum += x;
    return sum * SpectralGrid::kStep_nm;
}

double Spectrum::integrate_nm(double lo_nm, double hi_nm) const {
    if (hi_nm < lo_nm) std::swap(lo_nm, hi_nm);
    double sum = 0.0;
    for (int i = 0; i < SpectralGrid::kCount; ++i) {
        const double c = SpectralGrid::wavelength_nm(i);
        const double a = std::max(lo_nm, c - 0.5 * SpectralGrid::kStep_nm);
        const double b = std::min(hi_nm, c + 0.5 * SpectralGrid::kStep_nm);
        if (b > a) sum += v_[i] * (b - a);
    }
    return sum;
}

double Spectrum::max() const {
    return *std::max_element(v_.begin(), v_.end());
}

Spectrum& Spectrum::operator+=(const Spectrum& o) {
    for (int i = 0; i < SpectralGrid::kCount; ++i)
        v_[i] += o.v_[i];
    return *this;
}
Spectrum& Spectrum::operator-=(const Spectrum& o) {
    for (int i = 0; i < SpectralGrid::kCount; ++i)
        v_[i] -= o.v_[i];
    return *this;
}
Spectrum& Spectrum::operator*=(const Spectrum& o) {
    for (int i = 0; i < SpectralGrid::kCount; ++i)
        v_[i] *= o.v_[i];
    return *this;
}
Spectrum& Spectrum::operator*=(double k) {
    for (double& x : v_)
        x *= k;
    return *this;
}

double integrateProduct_nm(const Spectrum& a, const Spectrum& b) {
    double sum = 0.0;
    for (int i = 0; i < SpectralGrid::kCount; ++i)
        sum += a[i] * b[i];
    return sum * SpectralGrid::kStep_nm;
}

namespace {

// Exact integral over [a, b] of the piecewise-linear curve through (x, y), with the given
// treatment outside [x.front(), x.back()].
double integratePiecewiseLinear(const std::vector<double>& x, const std::vector<double>& y,
                                double a, double b, Extrapolation outside) {
    double sum = 0.0;
    if (outside == Extrapolation::Clamp) {
        if (a < x.front()) sum += y.front() * (std::min(b, x.front()) - a);
        if (b > x.back()) sum += y.back() * (b - std::max(a, x.back()));
    }
    const double lo = std::max(a, x.front());
    const double hi = std::min(b, x.back());
    if (hi <= lo) return sum;
    // First segment whose right end is beyond lo.
    std::size_t k = static_cast<std::size_t>(std::upper_bound(x.begin(), x.end(), lo) - x.begin());
    k = std::max<std::size_t>(k, 1);
    for (; k < x.size() && x[k - 1] < hi; ++k) {
        const double x0 = x[k - 1];
        const double x1 = x[k];
        const double s0 = std::max(lo, x0);
        const double s1 = std::min(hi, x1);
        if (s1 <= s0) continue;
        const double slope = (y[k] - y[k - 1]) / (x1 - x0);
        const double ys0 = y[k - 1] + slope * (s0 - x0);
        const double ys1 = y[k - 1] + slope * (s1 - x0);
        sum += 0.5 * (ys0 + ys1) * (s1 - s0);
    }
    return sum;
}

struct LengthUnit {
    const char* name;
    double metres;
};
constexpr LengthUnit kLengths[] = {
    {"nm", 1e-9}, {"um", 1e-6}, {"mm", 1e-3}, {"cm", 1e-2}, {"m", 1.0}};

}  // namespace

Spectrum TabulatedSpectrum::resample(Extrapolation outside) const {
    Spectrum s;
    const double h = 0.5 * SpectralGrid::kStep_nm;
    for (int i = 0; i < SpectralGrid::kCount; ++i) {
        const double c = SpectralGrid::wavelength_nm(i);
        s[i] = integratePiecewiseLinear(wavelength_nm, value, c - h, c + h, outside) /
               SpectralGrid::kStep_nm;
    }
    return s;
}

double TabulatedSpectrum::integrate_nm() const {
    return integratePiecewiseLinear(wavelength_nm, value, wavelength_nm.front(),
                                    wavelength_nm.back(), Extrapolation::Zero);
}

namespace {

// One unit token ("W", "cm-2", "um-1"): its factor to SI-with-nm and canonical form; false if
// the token is not a unit (then it belongs to the quantity's name).
bool parseUnitToken(std::string_view tok, double* factor, std::string* canon) {
    const std::size_t digitPos = tok.find_first_of("-0123456789");
    const std::string base(tok.substr(0, digitPos));
    int exponent = 1;
    if (digitPos != std::string_view::npos) {
        const std::string expText(tok.substr(digitPos));
        char* end = nullptr;
        const long e = std::strtol(expText.c_str(), &end, 10);
        if (end != expText.c_str() + expText.size() || e == 0) return false;
        exponent = static_cast<int>(e);
    }
    for (const auto& l : kLengths) {
        if (base != l.name) continue;
        if (exponent == -1) {
            *factor = 1e-9 / l.metres;  // per wavelength: per <unit> -> per nm
            *canon = "nm-1";
        } else {
            *factor = std::pow(l.metres, exponent);  // area, volume, length -> m
            *canon = exponent == 1 ? "m" : "m" + std::to_string(exponent);
        }
        return true;
    }
    static constexpr const char* kOther[] = {"W", "sr", "lm", "lx",  "cd", "s",      "J",
                                             "A", "V",  "K",  "deg", "DC", "photons"};
    for (const char* o : kOther) {
        if (base == o) {
            *factor = 1.0;
            *canon = std::string(tok);
            return true;
        }
    }
    return false;
}

}  // namespace

double unitFactorFromColumnName(std::string_view column, std::string* unit, const FileLoc& loc) {
    // Tokens are '_'-separated; the unit is the longest run of unit tokens at the end
    // ("irradiance_derived_W_m-2_um-1" -> W m-2 um-1), or a final "rel"/"pct" alone.
    std::vector<std::string_view> toks;
    for (std::size_t pos = 0;;) {
        const std::size_t next = column.find('_', pos);
        toks.push_back(column.substr(pos, next == std::string_view::npos ? next : next - pos));
        if (next == std::string_view::npos) break;
        pos = next + 1;
    }
    const auto noUnit = [&] {
        return SetupError(loc, "column '" + std::string(column) +
                                   "' carries no unit suffix (expected e.g. _nm, _rel, "
                                   "_W_m-2_sr-1_nm-1)");
    };
    if (toks.size() < 2) throw noUnit();
    if (toks.back() == "rel" || toks.back() == "pct") {
        *unit = "1";
        return toks.back() == "pct" ? 0.01 : 1.0;
    }
    double factor = 1.0;
    std::vector<std::string> canon;
    std::size_t i = toks.size();
    while (i > 1) {
        double f = 1.0;
        std::string c;
        if (!parseUnitToken(toks[i - 1], &f, &c)) break;
        factor *= f;
        canon.insert(canon.begin(), c);
        --i;
    }
    if (canon.empty()) throw noUnit();
    std::string joined;
    for (const auto& c : canon)
        joined += (joined.empty() ? "" : " ") + c;
    *unit = joined;
    return factor;
}

TabulatedSpectrum loadSpectrumCsv(const std::filesystem::path& path,
                                  std::string_view wavelengthColumn, std::string_view valueColumn) {
    const CsvTable csv = CsvTable::load(path);
    // "wavelength_*": the first column named wavelength_<unit>, in whichever length unit.
    if (wavelengthColumn.size() > 1 &&
        wavelengthColumn.substr(wavelengthColumn.size() - 2) == "_*") {
        const std::string_view prefix = wavelengthColumn.substr(0, wavelengthColumn.size() - 1);
        for (const std::string& h : csv.header()) {
            if (h.size() > prefix.size() && h.compare(0, prefix.size(), prefix) == 0) {
                wavelengthColumn = h;
                break;
            }
        }
    }
    const std::size_t wc = csv.column(wavelengthColumn);
    const std::size_t vc = csv.column(valueColumn);

    std::string wlUnit;
    const double wlFactor = unitFactorFromColumnName(wavelengthColumn, &wlUnit, csv.headerLoc());
    if (wlUnit != "m") {
        throw SetupError(csv.headerLoc(), "wavelength column '" + std::string(wavelengthColumn) +
                                              "' must be a length (_nm, _um or _m)");
    }
    TabulatedSpectrum t;
    t.loc = FileLoc{csv.file()};
    t.source = csv.commentValue("source");
    const double valueFactor = unitFactorFromColumnName(valueColumn, &t.unit, csv.headerLoc());
    for (std::size_t r = 0; r < csv.rowCount(); ++r) {
        const double wl_nm = csv.number(r, wc) * wlFactor * 1e9;
        const double v = csv.number(r, vc) * valueFactor;
        if (!t.wavelength_nm.empty() && wl_nm <= t.wavelength_nm.back()) {
            throw SetupError(csv.rowLoc(r), "wavelengths must increase strictly");
        }
        t.wavelength_nm.push_back(wl_nm);
        t.value.push_back(v);
    }
    if (t.wavelength_nm.size() < 2) throw SetupError(t.loc, "a spectrum needs at least 2 rows");
    return t;
}

}  // namespace nvs
