#pragma once
// The 1-D multi-layer heat balance of one surface (docs/thermal.md §4).
//
// Grid: nodes at the exposed face, at every layer interface and inside the layers, spaced
// geometrically from firstCell_m at the face (ratio `growth`, at most maxCell_m), each layer's
// cells scaled to fill it exactly. Node i holds half of each adjacent cell (vertex-centred
// finite volumes): capacity C_i = Σ ρc Δz/2 [J/m²K], conductance between neighbours
// G = k/Δz [W/m²K], exact at layer interfaces.
//
// Time: backward Euler (unconditionally stable, no oscillation with the fine surface cells that
// Crank–Nicolson would give), all fluxes at the step's end:
//   C_i (T_i' − T_i)/Δt = Σ_j G_ij (T_j' − T_i') + q_i(T'),
// with q_0 the surface balance
//   q_s(T) = α_s E_sw + ε_h [F r L↓ + (1 − F) σT_a⁴] − ε_h σT⁴ − h_c(T)(T − T_a)
// (r: the anisotropic sky's weight for the tilt, forcing.h TiltedSky; surroundings below the
// horizon radiate as blackbodies at the air temperature), plus the latent heat q_lat(T) of dew
// (condensation below the dew point; evaporation of the water held, at most all of it in one
// step) and of transpiration through a surface resistance while the surface is dry
// (forcing.h latentFlux_W_m2), and at the last node the back boundary (none, a fixed
// temperature, or h_b (T_b − T) + q_b). The surface terms are linearised about the latest
// iterate and the tridiagonal system solved again until the surface temperature moves less than
// 1e-7 K (Newton on εσT⁴ and q_lat, fixed point on h_c(T), half steps after 8 solves), so the
// step conserves energy to that tolerance: Σ C_i ΔT_i = Δt (q_s(T_0') + q_back).

#include <cstdint>
#include <vector>

#include "sim/thermal/forcing.h"
#include "sim/thermal/material.h"

namespace nvs::thermal {

struct GridParams {
    double firstCell_m = 0.5e-3;
    double growth = 1.25;
    double maxCell_m = 0.02;
};

// A surface class's geometry and exposure (what the scene supplies besides the material).
struct Exposure {
    Orientation orientation;
    double skyView = 1.0;  // sky-view factor F of the surface
    // Short-wave reflectance of the ground the surface sees (grass 0.16–0.26: Oke, Boundary
    // Layer Climates, Table 1.1).
    double groundAlbedo = 0.2;
    double deepTemperature_K = 0.0;  // > 0: replaces a fixed back's temperature
};

// The fluxes of the last step at its end [W/m²], positive into the surface.
struct StepFluxes {
    double absorbedShortwave_W_m2 = 0.0;
    double absorbedLongwave_W_m2 = 0.0;
    double emitted_W_m2 = 0.0;        // ε_h σ T⁴ (leaves)
    double convected_W_m2 = 0.0;      // h_c (T − T_a) (leaves)
    double back_W_m2 = 0.0;           // into the stack through the back boundary
    double latent_W_m2 = 0.0;         // dew and transpiration: condensation (+), evaporation (−)
    double transpiration_W_m2 = 0.0;  // of which through the leaves (≤ 0)
};

class SurfaceSolver {
  public:
    // Validates (SetupError at the material's place) and builds the grid; the profile starts
    // uniform at initial_K.
    SurfaceSolver(const ThermalMaterial& m, const Exposure& e, const GridParams& g,
                  double initial_K);

    // One backward-Euler step of dt_s ending at the forcing f. Per step: no allocation, no
    // throw.
    void step(const ForcingSample& f, double sunlitFraction, double dt_s) noexcept;
    // Validation steps (analytic cases): the surface takes a prescribed net flux q_W_m2 (into
    // the surface), or is held at surface_K; the back boundary as in step with the air at air_K.
    void stepPrescribedFlux(double q_W_m2, double air_K, double dt_s) noexcept;
    void stepPrescribedSurface(double surface_K, double air_K, double dt_s) noexcept;

    double surface_K() const { return T_.front(); }
    const std::vector<double>& depths_m() const { return z_; }
    const std::vector<double>& temperatures_K() const { return T_; }
    const std::vector<double>& capacities_J_m2K() const { return C_; }
    void setTemperatures(const std::vector<double>& T_K) { T_ = T_K; }
    const StepFluxes& lastFluxes() const { return flux_; }
    double dew_kg_m2() const { return dew_kg_m2_; }
    // Steps whose surface iteration had not settled to 1e-7 K after 60 solves (a counter, not
    // an error: the step keeps its last iterate).
    std::uint64_t unconvergedSteps() const { return unconverged_; }
    void setDew_kg_m2(double d) { dew_kg_m2_ = d; }
    std::size_t stateBytes() const;
    const ThermalMaterial& material() const { return m_; }
    const Exposure& exposure() const { return e_; }

  private:
    double backTemperature_K(const WeatherSample& w) const noexcept;
    void solveTridiagonal(std::size_t n) noexcept;
    // One linear solve of the step: the surface node takes q + dq (T − ts) (or is held at ts
    // when holdSurface); returns the new surface temperature (in x_).
    double solveStep(double q, double dq, double ts, double tb, bool holdSurface,
                     double dt_s) noexcept;
    void finishStep(double tb) noexcept;

    ThermalMaterial m_;
    Exposure e_;
    TiltedSky sky_;  // the anisotropic sky's weight for this orientation
    double emissivity_ = 0.95;
    std::vector<double> z_, T_, C_, G_;            // nodes; G_[i] links node i and i + 1
    std::vector<double> a_, b_, c_, d_, x_, old_;  // work arrays (sized at construction)
    StepFluxes flux_;
    double dew_kg_m2_ = 0.0;  // water held on the surface
    std::uint64_t unconverged_ = 0;
};

}  // namespace nvs::thermal
