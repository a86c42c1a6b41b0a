#pragma once
// Spectra on nvstim's one wavelength grid (docs/design.md §3).
//
// Grid: 350–1100 nm in 1 nm steps (751 samples). 1 nm, not 5 nm, because the structure the
// camera band sees is narrower than 5 nm: the O2 A-band (759–770 nm), the water-vapour bands,
// and the airglow lines (OI 557.7, Na D 589, OI 630.0) that the night sky is made of; the CIE
// V(λ) table is defined at 1 nm too. The cost is small: a spectrum is 6 KB, and per-frame work
// uses precomputed band integrals, never spectra.
//
// Sample i is the mean of the spectral density over the bin [λ_i − 0.5 nm, λ_i + 0.5 nm], so
// integrals are bin sums and resampling conserves energy whatever the source grid (a 0.1 nm
// solar spectrum or the thesis's 50 nm night-sky table).

#include <array>
#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "sim/core/error.h"

namespace nvs {

struct SpectralGrid {
    static constexpr double kMin_nm = 350.0;
    static constexpr double kMax_nm = 1100.0;
    static constexpr double kStep_nm = 1.0;
    static constexpr int kCount = 751;
    static constexpr double wavelength_nm(int i) { return kMin_nm + kStep_nm * i; }
    static_assert(kMin_nm + kStep_nm * (kCount - 1) == kMax_nm);
};

// A spectral quantity on SpectralGrid. For a spectral density the unit is "per nm"
// (e.g. W m^-2 sr^-1 nm^-1); for a dimensionless curve (reflectance, QE, V(λ)) it is 1.
class Spectrum {
  public:
    Spectrum() = default;
    explicit Spectrum(double constant) { v_.fill(constant); }

    // Samples f(λ_nm) at the bin centres (midpoint rule; for smooth f the bin-mean error is
    // f''·Δ²/24, below 1e-5 relative for Planck curves on this grid).
    template <typename F>
    static Spectrum fromFunction(F&& f) {
        Spectrum s;
        for (int i = 0; i < SpectralGrid::kCount; ++i)
            s.v_[i] = f(SpectralGrid::wavelength_nm(i));
        return s;
    }

    double operator[](int i) const { return v_[i]; }
    double& operator[](int i) { return v_[i]; }
    static constexpr int size() { return SpectralGrid::kCount; }
    const std::array<double, SpectralGrid::kCount>& values() const { return v_; }

    // Linear interpolation between bin centres; 0 outside the grid.
    double at_nm(double wavelength_nm) const;

    // ∫ s(λ) dλ over the whole grid, λ in nm.
    double integrate_nm() const;
    // ∫ s(λ) dλ over [lo_nm, hi_nm] (partial bins counted by their overlap).
    double integrate_nm(double lo_nm, double hi_nm) const;
    double max() const;

    Spectrum& operator+=(const Spectrum& o);
    Spectrum& operator-=(const Spectrum& o);
    Spectrum& operator*=(const Spectrum& o);
    Spectrum& operator*=(double k);
    friend Spectrum operator+(Spectrum a, const Spectrum& b) { return a += b; }
    friend Spectrum operator-(Spectrum a, const Spectrum& b) { return a -= b; }
    friend Spectrum operator*(Spectrum a, const Spectrum& b) { return a *= b; }
    friend Spectrum operator*(Spectrum a, double k) { return a *= k; }
    friend Spectrum operator*(double k, Spectrum a) { return a *= k; }

  private:
    std::array<double, SpectralGrid::kCount> v_{};
};

// ∫ a(λ)·b(λ) dλ without building the product.
double integrateProduct_nm(const Spectrum& a, const Spectrum& b);

enum class Extrapolation { Zero, Clamp };

// A spectrum as tabulated in a file, on its own wavelength grid, in SI-with-nm units:
// wavelengths in nm, spectral densities per nm, lengths other than wavelength in m.
struct TabulatedSpectrum {
    std::vector<double> wavelength_nm;
    std::vector<double> value;
    std::string unit;    // e.g. "W m-2 sr-1 nm-1", "1" for dimensionless
    std::string source;  // from the file's "# source:" comment, "" if none
    FileLoc loc;

    // Bin means of the piecewise-linear curve through the points (energy conserving). Outside
    // the tabulated range: 0, or the end value held.
    Spectrum resample(Extrapolation outside = Extrapolation::Zero) const;
    // ∫ over the tabulated range of the piecewise-linear curve.
    double integrate_nm() const;
};

// Loads columns of a CSV file whose names carry their units (the convention of
// tests/data/thesis: "wavelength_um", "radiance_W_cm-2_sr-1_um-1", "response_rel").
// The wavelength column ends in _nm, _um or _m ("wavelength_*": whichever the file has). The value
// column's unit tokens are converted: a length to the power −1 is per-wavelength (→ nm⁻¹), to the
// power −2 per-area (→ m⁻²); "rel" is dimensionless and "pct" is divided by 100. Unknown tokens are
// errors naming the header line. Wavelengths must increase strictly.
TabulatedSpectrum loadSpectrumCsv(const std::filesystem::path& path,
                                  std::string_view wavelengthColumn, std::string_view valueColumn);

// Converts a column name's unit suffix (everything after the first '_') to SI-with-nm.
// Returns the factor to multiply values by and writes the canonical unit. Exposed for tests.
double unitFactorFromColumnName(std::string_view column, std::string* unit, const FileLoc& loc);

}  // namespace nvs
