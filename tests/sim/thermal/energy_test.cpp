// Energy conservation over a day of real forcing: the energy the surface absorbed, minus what
// it emitted and convected, minus what crossed the back, equals the change of heat stored in
// the layers, within 0.5 % of the gross flux Σ(|absorbed| + |emitted| + |convected| +
// |latent|)·Δt, the latent heat of dew included. The
// test rebuilds every term itself: the fluxes from the forcing models and the surface
// temperature, the stored heat from the node depths and the layers' ρc (half cells).
#include <gtest/gtest.h>

#include <cmath>

#include "sim/core/units.h"
#include "sim/thermal/heat_balance.h"
#include "sim/thermal/material.h"

namespace nvs::thermal {
namespace {

const std::string kConfig = std::string(NVS_SOURCE_DIR) + "/config/thermal/";

// ρc of the layer holding depth z.
double rhoCAt(const ThermalMaterial& m, double z) {
    double top = 0.0;
    for (const Layer& l : m.layers) {
        if (z <= top + l.thickness_m) return l.density_kg_m3 * l.specificHeat_J_kgK;
        top += l.thickness_m;
    }
    return 0.0;
}

// Heat stored per area relative to 0 K: Σ over cells of ρc Δz (T_i + T_{i+1})/2 (the solver's
// lumped half cells give the same sum).
double stored_J_m2(const SurfaceSolver& s) {
    const std::vector<double>& z = s.depths_m();
    const std::vector<double>& T = s.temperatures_K();
    double e = 0.0;
    for (std::size_t i = 0; i + 1 < z.size(); ++i)
        e += rhoCAt(s.material(), 0.5 * (z[i] + z[i + 1])) * (z[i + 1] - z[i]) * 0.5 *
             (T[i] + T[i + 1]);
    return e;
}

// Magnus (Alduchov & Eskridge 1996) and the Chilton–Colburn analogy for the dew's latent heat,
// written out here apart from the library: h_m = h_c/(ρ c_p Le^{2/3}), ρ_v = e/(R_v T).
double vapourDensity_kg_m3(double T_K) {
    const double t = T_K - 273.15;
    return 610.94 * std::exp(17.625 * t / (t + 243.04)) / (461.5 * T_K);
}
double dewLatent_W_m2(double hc, double T, double Ta, double Td) {
    const double rhoAir = 101325.0 / (287.05 * Ta);
    const double hm = hc / (rhoAir * 1007.0 * std::pow(0.87, 2.0 / 3.0));
    return 2.45e6 * hm * (vapourDensity_kg_m3(Td) * Td / Ta - vapourDensity_kg_m3(T));
}

struct Budget {
    double net_J_m2 = 0.0, gross_J_m2 = 0.0, stored_J_m2 = 0.0, latent_J_m2 = 0.0;
};

Budget runDay(const ThermalMaterial& m, const Exposure& e) {
    const WeatherSeries w = WeatherSeries::load(kConfig + "weather/rochester-1998-09-02.csv");
    astro::Site site;
    site.lat_deg = 43.16856;
    site.lon_deg = -77.61583;
    site.height_m = 150.0;
    const astro::Ephemeris eph(site);
    const double t0 = w.start_s(), dt = 60.0;
    const astro::AstroTime at0 = astro::astroTimeFromUtc(astro::parseIsoUtc("1998-08-31T00:00Z"));
    const ForcingParams fp;
    SurfaceSolver s(m, e, GridParams{}, 290.0);
    const double cosTilt = std::cos(e.orientation.tilt_rad);
    const double sigma = kStefanBoltzmann_W_m2_K4;
    const double eps = m.emissivityHemispherical;
    Budget b;
    double water = 0.0;  // kg/m² of dew
    b.stored_J_m2 = -stored_J_m2(s);
    // 1998-09-01T06:00Z to 09-02T06:00Z: a day, then a clear night that ends with dew held.
    for (int i = 1801; i <= 1800 + 1440; ++i) {
        const ForcingSample f = forcingAt(eph, at0, t0, w, fp, t0 + i * dt);
        s.step(f, 1.0, dt);
        const double T = s.surface_K(), Ta = f.weather.air_K;
        const double absorbed =
            m.solarAbsorptance * planeShortwave_W_m2(f, e.orientation, e.skyView, 1.0, 0.2) +
            eps * (e.skyView * f.longwaveDown_W_m2 + (1.0 - e.skyView) * sigma * std::pow(Ta, 4.0));
        const double emitted = eps * sigma * std::pow(T, 4.0);
        const double hc =
            convectionCoefficient_W_m2K(f.weather.wind_m_s, T, Ta, cosTilt, m.roughnessMultiplier);
        const double convected = hc * (T - Ta);
        // Dew: condensation, or evaporation of at most the water this test has seen condense.
        const double latent =
            std::max(dewLatent_W_m2(hc, T, Ta, f.weather.dewPoint_K), -2.45e6 * water / dt);
        water = std::max(0.0, water + latent / 2.45e6 * dt);
        // Back: conduction from the fixed node, or the film to the inside air.
        double back = m.backFlux_W_m2;
        const std::vector<double>& z = s.depths_m();
        const std::vector<double>& Tn = s.temperatures_K();
        const std::size_t n = z.size();
        if (m.back == BackBoundary::FixedTemperature)
            back =
                m.layers.back().conductivity_W_mK * (Tn[n - 1] - Tn[n - 2]) / (z[n - 1] - z[n - 2]);
        else if (m.back == BackBoundary::AirNode)
            back += m.backFilm_W_m2K *
                    ((m.backFollowsAir ? Ta + m.backAirOffset_K : m.backTemperature_K) - Tn[n - 1]);
        b.net_J_m2 += (absorbed - emitted - convected + latent + back) * dt;
        b.gross_J_m2 +=
            (std::abs(absorbed) + std::abs(emitted) + std::abs(convected) + std::abs(latent)) * dt;
        b.latent_J_m2 += std::abs(latent) * dt;
    }
    b.stored_J_m2 += stored_J_m2(s);
    return b;
}

TEST(HeatBalanceEnergy, ConservedOverADayInsulatedAndWithABack) {
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    struct Case {
        const char* material;
        double tilt_deg, skyView;
    };
    for (const Case& c : {Case{"concrete", 0.0, 1.0}, Case{"painted_metal", 0.0, 1.0},
                          Case{"painted_metal", 90.0, 0.5}, Case{"brick", 90.0, 0.5},
                          Case{"aluminium_polished", 30.0, 0.9}}) {
        ThermalMaterial m = lib.get(c.material, {});
        Exposure e;
        e.orientation.tilt_rad = c.tilt_deg * kRadPerDeg;
        e.orientation.azimuth_rad = kPi;  // facing south
        e.skyView = c.skyView;
        const Budget b = runDay(m, e);
        const double residual = b.net_J_m2 - b.stored_J_m2;
        EXPECT_LT(std::abs(residual), 0.005 * b.gross_J_m2) << c.material;
        std::printf(
            "%s tilt %.0f: net in %.4g J/m2, stored %.4g J/m2, |latent| %.3g J/m2, "
            "residual %.3g %% of gross\n",
            c.material, c.tilt_deg, b.net_J_m2, b.stored_J_m2, b.latent_J_m2,
            100.0 * residual / b.gross_J_m2);
    }
}

}  // namespace
}  // namespace nvs::thermal
