#include "sim/thermal/surface_solver.h"

#include <algorithm>
#include <cmath>

#include "sim/core/units.h"

namespace nvs::thermal {

namespace {
// Less water than this (a micrometre-thin film is 1e-3 kg/m²) counts as a dry surface.
constexpr double kDryBelow_kg_m2 = 1e-9;
}  // namespace

namespace {

// Appends one layer's cells to the grid: geometric sizes from `cell`, scaled to fill the layer.
// Returns the next cell size.
double addLayer(const Layer& l, double cell, const GridParams& g, std::vector<double>& z,
                std::vector<double>& C, std::vector<double>& G) {
    std::vector<double> sizes;
    double sum = 0.0, d = std::min(cell, l.thickness_m);
    while (sum < l.thickness_m * (1.0 - 1e-9)) {
        sizes.push_back(d);
        sum += d;
        d = std::min(d * g.growth, g.maxCell_m);
    }
    const double scale = l.thickness_m / sum;
    const double rc = l.density_kg_m3 * l.specificHeat_J_kgK;
    for (double s : sizes) {
        const double dz = s * scale;
        C.back() += 0.5 * rc * dz;
        C.push_back(0.5 * rc * dz);
        G.push_back(l.conductivity_W_mK / dz);
        z.push_back(z.back() + dz);
    }
    return std::min(sizes.back() * scale * g.growth, g.maxCell_m);
}

}  // namespace

SurfaceSolver::SurfaceSolver(const ThermalMaterial& m, const Exposure& e, const GridParams& g,
                             double initial_K)
    : m_(m), e_(e), sky_(e.orientation.tilt_rad), emissivity_(m.emissivityHemispherical) {
    if (!m.hasThermal()) throw SetupError(m.loc, "material '" + m.name + "' has no thermal layers");
    if (!(e.skyView >= 0.0 && e.skyView <= 1.0))
        throw SetupError("surface class of '" + m.name + "': sky-view factor outside [0, 1]");
    if (!(g.firstCell_m > 0.0 && g.growth >= 1.0 && g.maxCell_m >= g.firstCell_m))
        throw SetupError("heat balance grid: first cell > 0, growth ≥ 1, max cell ≥ first");
    z_.assign(1, 0.0);
    C_.assign(1, 0.0);
    double cell = g.firstCell_m;
    for (const Layer& l : m.layers)
        cell = addLayer(l, cell, g, z_, C_, G_);
    const double t0 = m.surfaceTemperature_K > 0.0 ? m.surfaceTemperature_K : initial_K;
    T_.assign(z_.size(), t0);
    if (m.back == BackBoundary::FixedTemperature && !m.layers.empty()) {
        T_.back() = e.deepTemperature_K > 0.0 ? e.deepTemperature_K : m.backTemperature_K;
    }
    const std::size_t n = z_.size();
    a_.assign(n, 0.0);
    b_ = c_ = d_ = x_ = old_ = a_;
}

std::size_t SurfaceSolver::stateBytes() const {
    return sizeof(*this) +
           sizeof(double) *
               (z_.capacity() + T_.capacity() + C_.capacity() + G_.capacity() + a_.capacity() +
                b_.capacity() + c_.capacity() + d_.capacity() + x_.capacity() + old_.capacity()) +
           sizeof(Layer) * m_.layers.capacity();
}

double SurfaceSolver::backTemperature_K(const WeatherSample& w) const noexcept {
    if (m_.back == BackBoundary::FixedTemperature)
        return e_.deepTemperature_K > 0.0 ? e_.deepTemperature_K : m_.backTemperature_K;
    if (m_.back == BackBoundary::AirNode)
        return m_.backFollowsAir ? w.air_K + m_.backAirOffset_K : m_.backTemperature_K;
    return 0.0;
}

void SurfaceSolver::solveTridiagonal(std::size_t n) noexcept {
    // Thomas algorithm on a_ (sub), b_ (diagonal), c_ (super), d_ (right side) → x_.
    for (std::size_t i = 1; i < n; ++i) {
        const double w = a_[i] / b_[i - 1];
        b_[i] -= w * c_[i - 1];
        d_[i] -= w * d_[i - 1];
    }
    x_[n - 1] = d_[n - 1] / b_[n - 1];
    for (std::size_t i = n - 1; i-- > 0;)
        x_[i] = (d_[i] - c_[i] * x_[i + 1]) / b_[i];
}

double SurfaceSolver::solveStep(double q, double dq, double ts, double tb, bool holdSurface,
                                double dt_s) noexcept {
    const std::size_t n = T_.size();
    const bool dirichlet = m_.back == BackBoundary::FixedTemperature;
    const std::size_t nu = dirichlet ? n - 1 : n;  // unknowns
    for (std::size_t i = 0; i < nu; ++i) {
        const double gl = i > 0 ? G_[i - 1] : 0.0;
        const double gr = i + 1 < n ? G_[i] : 0.0;
        a_[i] = -gl;
        c_[i] = (i + 1 < nu) ? -gr : 0.0;
        b_[i] = C_[i] / dt_s + gl + gr;
        d_[i] = C_[i] / dt_s * old_[i];
    }
    if (dirichlet) {
        d_[nu - 1] += G_[nu - 1] * tb;
    } else {
        if (m_.back == BackBoundary::AirNode) {
            b_[nu - 1] += m_.backFilm_W_m2K;
            d_[nu - 1] += m_.backFilm_W_m2K * tb;
        }
        d_[nu - 1] += m_.backFlux_W_m2;
    }
    if (holdSurface) {  // row 0 becomes T_0 = ts
        b_[0] = 1.0;
        c_[0] = 0.0;
        d_[0] = ts;
    } else {
        b_[0] -= dq;
        d_[0] += q - dq * ts;
    }
    solveTridiagonal(nu);
    return x_[0];
}

void SurfaceSolver::finishStep(double tb) noexcept {
    const std::size_t n = T_.size();
    const bool dirichlet = m_.back == BackBoundary::FixedTemperature;
    const std::size_t nu = dirichlet ? n - 1 : n;
    for (std::size_t i = 0; i < nu; ++i)
        T_[i] = x_[i];
    if (dirichlet) T_[n - 1] = tb;
    if (dirichlet)
        flux_.back_W_m2 = G_[n - 2] * (tb - T_[n - 2]);
    else if (m_.back == BackBoundary::AirNode)
        flux_.back_W_m2 = m_.backFilm_W_m2K * (tb - T_[n - 1]) + m_.backFlux_W_m2;
    else
        flux_.back_W_m2 = m_.backFlux_W_m2;
}

void SurfaceSolver::stepPrescribedFlux(double q_W_m2, double air_K, double dt_s) noexcept {
    if (T_.size() < 2) return;
    WeatherSample w;
    w.air_K = air_K;
    const double tb = backTemperature_K(w);
    old_ = T_;
    solveStep(q_W_m2, 0.0, T_[0], tb, false, dt_s);
    finishStep(tb);
}

void SurfaceSolver::stepPrescribedSurface(double surface_K, double air_K, double dt_s) noexcept {
    if (T_.size() < 2) return;
    WeatherSample w;
    w.air_K = air_K;
    const double tb = backTemperature_K(w);
    old_ = T_;
    solveStep(0.0, 0.0, surface_K, tb, true, dt_s);
    finishStep(tb);
}

void SurfaceSolver::step(const ForcingSample& f, double sunlitFraction, double dt_s) noexcept {
    const WeatherSample& w = f.weather;
    const double sigma = kStefanBoltzmann_W_m2_K4;
    const double ta4 = w.air_K * w.air_K * w.air_K * w.air_K;
    const double F = e_.skyView;
    const double cosTilt = std::cos(e_.orientation.tilt_rad);
    flux_.absorbedShortwave_W_m2 =
        m_.solarAbsorptance *
        planeShortwave_W_m2(f, e_.orientation, F, sunlitFraction, e_.groundAlbedo);
    const double skyRatio = sky_.ratio(f.longwaveDown_W_m2 / (sigma * ta4));
    flux_.absorbedLongwave_W_m2 =
        emissivity_ * (F * skyRatio * f.longwaveDown_W_m2 + (1.0 - F) * sigma * ta4);
    const double absorbed = flux_.absorbedShortwave_W_m2 + flux_.absorbedLongwave_W_m2;
    double ts = T_[0];
    auto h = [&](double T) {
        return convectionCoefficient_W_m2K(w.wind_m_s, T, w.air_K, cosTilt, m_.roughnessMultiplier);
    };
    if (m_.surfaceTemperature_K > 0.0 || T_.size() < 2) {  // a held source: nothing to solve
        flux_.emitted_W_m2 = emissivity_ * sigma * ts * ts * ts * ts;
        flux_.convected_W_m2 = h(ts) * (ts - w.air_K);
        flux_.back_W_m2 = 0.0;
        flux_.latent_W_m2 = 0.0;
        flux_.transpiration_W_m2 = 0.0;
        return;
    }
    const double tb = backTemperature_K(w);
    old_ = T_;  // same size: no allocation
    // Dew: condensation, or evaporation of at most the water held.
    // Transpiration: through the stomata (resistance by day or night) while the leaves are dry.
    const double maxEvaporation_W_m2 = kLatentHeat_J_kg * dew_kg_m2_ / dt_s;
    const double rs =
        f.sunAlt_rad > 0.0 ? m_.surfaceResistanceDay_s_m : m_.surfaceResistanceNight_s_m;
    const bool transpires = rs > 0.0 && dew_kg_m2_ <= 0.0;
    double dewPart = 0.0;
    auto latent = [&](double T, double hcT) {
        const double hm = massTransfer_m_s(hcT, w.air_K);
        const double dew = m_.collectsDew ? std::max(latentFlux_W_m2(hm, T, w.air_K, w.dewPoint_K),
                                                     -maxEvaporation_W_m2)
                                          : 0.0;
        const double leaves =
            transpires
                ? std::min(0.0, latentFlux_W_m2(1.0 / (1.0 / hm + rs), T, w.air_K, w.dewPoint_K))
                : 0.0;
        dewPart = dew;
        return dew + leaves;
    };
    double hc = 0.0, lat = 0.0;
    bool converged = false;
    for (int it = 0; it < 60; ++it) {
        // Newton on the emission and the dew, fixed point on h_c(T):
        // q(T) ≈ q(ts) + q'(ts)(T − ts).
        hc = h(ts);
        const double ts3 = ts * ts * ts;
        const double dlat = (latent(ts + 1e-3, hc) - latent(ts, hc)) / 1e-3;
        lat = latent(ts, hc);  // last: leaves dewPart at ts
        const double q = absorbed - emissivity_ * sigma * ts3 * ts - hc * (ts - w.air_K) + lat;
        const double dq = -4.0 * emissivity_ * sigma * ts3 - hc + dlat;
        const double next = solveStep(q, dq, ts, tb, false, dt_s);
        const double moved = std::abs(next - ts);
        // Newton first; past 8 solves (a kink of the latent term — dew point, a drying
        // surface — can make it alternate) half steps, which settle on the continuous balance.
        ts = it < 8 ? next : ts + 0.5 * (next - ts);
        if (moved < 1e-7) {
            converged = true;
            break;
        }
    }
    if (!converged) ++unconverged_;
    finishStep(tb);
    flux_.emitted_W_m2 = emissivity_ * sigma * ts * ts * ts * ts;
    flux_.convected_W_m2 = hc * (ts - w.air_K);
    flux_.latent_W_m2 = lat;
    flux_.transpiration_W_m2 = lat - dewPart;
    dew_kg_m2_ += dewPart / kLatentHeat_J_kg * dt_s;
    if (dew_kg_m2_ < kDryBelow_kg_m2) dew_kg_m2_ = 0.0;  // rounding leftovers: dry
}

}  // namespace nvs::thermal
