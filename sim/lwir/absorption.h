#pragma once
// Gas absorption over the thermal band (docs/lwir.md §2): spectral mean transmittance on a
// 5 cm⁻¹ wavenumber grid from 550 to 1500 cm⁻¹ (18.2–6.67 µm) for a path through air.
//
//   water-vapour continuum   Roberts, Selby & Biberman (1976), self- and foreign-broadened,
//                            exp[1800 K (1/T − 1/296 K)]: optical depth, multiplicative
//   water-vapour lines       Goody random model, Rodgers & Walshaw (1966) interval parameters
//   CO2 15 µm, O3 9.6 µm     exponential band shape (Edwards 1976) with Goody line overlap
//
// An inhomogeneous path (the slant path through the layered sky) adds its segments with the
// Curtis–Godson approximation: per line absorber the weak-line depth W = Σ Wᵢ and the
// intensity-weighted line-width parameter y = Σ Wᵢ yᵢ / Σ Wᵢ, so the transmittance of the
// whole path is t = exp(−W / √(1 + W/y)) (Goody 1964, "Atmospheric Radiation", §6.2).
// The coefficients are read from config/lwir/*.csv, each naming its source; a missing or
// malformed file, or a value out of range, is a SetupError with file:line.

#include <array>
#include <cstdint>
#include <filesystem>
#include <vector>

namespace nvs::lwir {

struct Grid {
    static constexpr double kFirst_cm1 = 550.0;
    static constexpr double kStep_cm1 = 5.0;
    static constexpr int kSize = 191;  // 550 … 1500 cm⁻¹
    static constexpr double wavenumber_cm1(int i) { return kFirst_cm1 + kStep_cm1 * i; }
    static constexpr double wavelength_um(int i) { return 1e4 / wavenumber_cm1(i); }
};
using Spectral = std::array<double, Grid::kSize>;

struct ContinuumCoefficients {
    double a_cm2_atm = 0.0;  // per molecule
    double b_cm2_atm = 0.0;
    double beta_cm = 0.0;
    double tRef_K = 0.0;
    double t0_K = 0.0;
    double gamma = 0.0;
};

struct LineInterval {
    double lo_cm1 = 0.0, hi_cm1 = 0.0;
    double kOverDelta_cm2_g = 0.0;
    double piAlphaOverDelta = 0.0;
    double a_per_K = 0.0, b_per_K2 = 0.0;  // S/S0 = exp[a (T − 260) + b (T − 260)²]
};

struct ExponentialBand {
    double center_cm1 = 0.0;
    double alpha_cm1_per_g_m2 = 0.0;
    double omega0_cm1 = 0.0, tOmega_K = 0.0;
    double beta0 = 0.0, tBeta_K = 0.0;
    double n = 1.0, b = 1.0;
};

struct AbsorptionData {
    ContinuumCoefficients continuum;
    std::vector<LineInterval> h2oLines;
    ExponentialBand co2, o3;

    // Reads config/lwir/{h2o_continuum_roberts1976, h2o_lines_rodgers_walshaw1966,
    // band_models_co2_o3}.csv under configDir.
    static AbsorptionData load(const std::filesystem::path& configDir);
    // A hash of every coefficient (for cache keys).
    std::uint64_t hash() const;
};

// The air in one segment of a path.
struct AirState {
    double temperature_K = 288.15;
    double pressure_Pa = 101325.0;
    double vapourPressure_Pa = 1000.0;
    double co2_ppm = 420.0;  // NOAA global mean 2023, 419.3 ppm (gml.noaa.gov/ccgg/trends)
    double o3_ppb = 30.0;    // rural surface ozone at night, order of magnitude (docs/lwir.md)
};

// Absorber amounts accumulated along a path, per grid point; transmittance on demand.
class PathAbsorption {
  public:
    explicit PathAbsorption(const AbsorptionData& data);
    void reset();
    // Adds a homogeneous segment of `length_m` (≥ 0) of air in `state`.
    void add(const AirState& state, double length_m);
    // Mean transmittance of the accumulated path at grid point i (within the active range).
    double transmittance(int i) const;
    // Restricts add() to grid points lo…hi (inclusive; a band's support) to save time; the
    // default is the whole grid.
    void setActive(int lo, int hi);

  private:
    static constexpr int kLineAbsorbers = 3;  // H2O lines, CO2, O3
    const AbsorptionData* data_;
    int lo_ = 0, hi_ = Grid::kSize - 1;
    Spectral continuumBase_cm2_atm_{};  // a + b exp(−β ν)
    Spectral h2oK_{}, h2oY_{}, h2oA_{}, h2oB_{};
    Spectral continuumDepth_{};
    std::array<Spectral, kLineAbsorbers> w_{}, wy_{};
};

// Spectral transmittance of a homogeneous horizontal path.
Spectral homogeneousTransmittance(const AbsorptionData& data, const AirState& air, double range_m);

}  // namespace nvs::lwir
