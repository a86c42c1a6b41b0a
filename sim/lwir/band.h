#pragma once
// Band radiometry for a camera's spectral response R(λ) (docs/lwir.md §3):
//
//   B_band(T)  = ∫ R(λ) B_λ(λ, T) dλ                                  [W m⁻² sr⁻¹]
//   τ_band(r)  = ∫ R τ(λ, r) B_λ(λ, T_air) dλ / B_band(T_air)
//   L_path(r)  = ∫ R (1 − τ(λ, r)) B_λ(λ, T_air) dλ                   (homogeneous path)
//
// on the absorption grid (sim/lwir/absorption.h): each 5 cm⁻¹ cell carries the weight
// w_i = ∫_cell R(λ) dλ [µm] (16 sub-steps, so a band edge inside a cell counts its part), and
// B_λ is taken at the cell centre. The inverse (brightness temperature) is Newton's method on
// B_band(T).

#include <filesystem>
#include <string>

#include "sim/lwir/absorption.h"

namespace nvs::lwir {

class BandResponse {
  public:
    // A flat response of 1 between lo and hi µm (6.7 ≤ lo < hi ≤ 18 µm).
    static BandResponse flat(double lo_um, double hi_um);
    // A response from a CSV with columns wavelength_um, response (linear between rows, zero
    // outside, rows in increasing wavelength, response ≥ 0); errors name file:line.
    static BandResponse fromCsv(const std::filesystem::path& file);

    double weight_um(int i) const { return w_[i]; }
    // The first and last grid points with a non-zero weight.
    int firstIndex() const;
    int lastIndex() const;
    const std::string& name() const { return name_; }
    std::uint64_t hash() const;

  private:
    template <typename F>
    static BandResponse integrate(F response, std::string name);
    Spectral w_{};
    std::string name_;
};

// Spectral radiance of a blackbody at grid point i [W m⁻² sr⁻¹ µm⁻¹].
double planckGrid_W_m2_sr_um(int i, double temperature_K);

// Band radiance of a blackbody [W m⁻² sr⁻¹] and its derivative [W m⁻² sr⁻¹ K⁻¹].
double bandRadiance_W_m2_sr(const BandResponse& band, double temperature_K);
double bandRadianceDerivative_W_m2_sr_K(const BandResponse& band, double temperature_K);
// The temperature of the blackbody with this band radiance (> 0) [K].
double brightnessTemperature_K(const BandResponse& band, double radiance_W_m2_sr);

// Band-integrated ∫ R X(λ) B_λ(λ, T) dλ of a spectral factor X on the grid.
double bandIntegral_W_m2_sr(const BandResponse& band, const Spectral& x, double temperature_K);

struct PathBand {
    double transmittance = 1.0;         // τ_band, weighted by B(T_air)
    double pathRadiance_W_m2_sr = 0.0;  // L_path
};

// τ_band and L_path of a horizontal homogeneous path of `range_m` (≥ 0) through `air`.
PathBand horizontalPath(const AbsorptionData& data, const BandResponse& band, const AirState& air,
                        double range_m);

}  // namespace nvs::lwir
