// Energy conservation over a day of real forcing: the energy the surface absorbed, minus what
// it emitted and convected, minus what crossed the back, equals the change of heat stored in
// the layers, within 0.5 % of the gross flux Σ(|absorbed| + |emitted| + |convected| +
// |latent|)·Δt, the latent heat of dew and transpiration included. The
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

// Magnus (Alduchov & Eskridge 1996) and the Chilton–Colburn analogy for the latent heat,
// written out here apart from the library: h_m = h_c/(ρ c_p Le^{2/3}), ρ_v = e/(R_v T).
double vapourDensity_kg_m3(double T_K) {
    const double t = T_K - 273.15;
    return 610.94 * std::exp(17.625 * t / (t + 243.04)) / (461.5 * T_K);
}
// rs: a stomatal resistance in series (s/m), 0 for a wet surface.
double latent_W_m2(double hc, double T, double Ta, double Td, double rs) {
    const double rhoAir = 101325.0 / (287.05 * Ta);
    const double hm = hc / (rhoAir * 1007.0 * std::pow(0.87, 2.0 / 3.0));
    const double g = 1.0 / (1.0 / hm + rs);
    return 2.45e6 * g * (vapourDensity_kg_m3(Td) * Td / Ta - vapourDensity_kg_m3(T));
}

struct Budget {
    double net_J_m2 = 0.0, gross_J_m2 = 0.0, stored_J_m2 = 0.0, latent_J_m2 = 0.0;
    double transpired_kg_m2 = 0.0;
    double evaporated_kg_m2 = 0.0;  // −Σ latent / L_v
    double ghi_J_m2 = 0.0, tMax_K = 0.0, tMin_K = 1e9, wind_m_s = 0.0, dew_K = 0.0;  // weather
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
    const TiltedSky sky(e.orientation.tilt_rad);
    Budget b;
    double water = 0.0;  // kg/m² of dew
    b.stored_J_m2 = -stored_J_m2(s);
    // 1998-09-01T06:00Z to 09-02T06:00Z: a day, then a clear night that ends with dew held.
    for (int i = 1801; i <= 1800 + 1440; ++i) {
        const ForcingSample f = forcingAt(eph, at0, t0, w, fp, t0 + i * dt);
        s.step(f, 1.0, dt);
        const double T = s.surface_K(), Ta = f.weather.air_K;
        // The sky part weighted for the tilt (the anisotropic sky, forcing.h TiltedSky).
        const double r = sky.ratio(f.longwaveDown_W_m2 / (sigma * std::pow(Ta, 4.0)));
        const double absorbed =
            m.solarAbsorptance * planeShortwave_W_m2(f, e.orientation, e.skyView, 1.0, 0.2) +
            eps * (e.skyView * r * f.longwaveDown_W_m2 +
                   (1.0 - e.skyView) * sigma * std::pow(Ta, 4.0));
        const double emitted = eps * sigma * std::pow(T, 4.0);
        const double hc =
            convectionCoefficient_W_m2K(f.weather.wind_m_s, T, Ta, cosTilt, m.roughnessMultiplier);
        const double convected = hc * (T - Ta);
        // Dew: condensation, or evaporation of at most the water this test has seen condense;
        // transpiration through the stomata (day or night resistance) while the leaves are dry.
        const double Td = f.weather.dewPoint_K;
        const double dew =
            m.collectsDew ? std::max(latent_W_m2(hc, T, Ta, Td, 0.0), -2.45e6 * water / dt) : 0.0;
        const double rs =
            f.sunAlt_rad > 0.0 ? m.surfaceResistanceDay_s_m : m.surfaceResistanceNight_s_m;
        const double leaves =
            rs > 0.0 && water <= 0.0 ? std::min(0.0, latent_W_m2(hc, T, Ta, Td, rs)) : 0.0;
        const double latent = dew + leaves;
        water += dew / 2.45e6 * dt;
        if (water < 1e-9) water = 0.0;  // the solver's dry threshold
        b.transpired_kg_m2 -= leaves / 2.45e6 * dt;
        b.evaporated_kg_m2 -= latent / 2.45e6 * dt;
        b.ghi_J_m2 += f.sun.ghi_W_m2 * dt;
        b.tMax_K = std::max(b.tMax_K, Ta);
        b.tMin_K = std::min(b.tMin_K, Ta);
        b.wind_m_s += f.weather.wind_m_s / 1440.0;
        b.dew_K += Td / 1440.0;
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
    for (const Case& c : {Case{"grass", 0.0, 1.0}, Case{"concrete", 0.0, 1.0},
                          Case{"painted_metal", 0.0, 1.0}, Case{"painted_metal", 90.0, 0.5},
                          Case{"brick", 90.0, 0.5}, Case{"aluminium_polished", 30.0, 0.9}}) {
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

// Grass's evaporation over the day against the FAO-56 Penman–Monteith reference
// evapotranspiration of the same weather (Allen, Pereira, Raes & Smith 1998, "Crop
// evapotranspiration", FAO Irrigation and Drainage Paper 56: eq. 6 with eqs. 7, 8, 11–13, 21,
// 37, 39, 47; clipped grass is its reference crop): an independent model of the same process,
// daily, with its own aerodynamic resistance (208/u₂) and a 70 s/m surface resistance. Within
// 35 %.
struct Fao56 {
    double et0_mm, rso_MJ_m2;
};
Fao56 fao56(const Budget& b, double lat_rad, int dayOfYear, double z_m) {
    auto e0 = [](double tC) { return 0.6108 * std::exp(17.27 * tC / (tC + 237.3)); };  // kPa
    const double tmax = b.tMax_K - 273.15, tmin = b.tMin_K - 273.15, t = 0.5 * (tmax + tmin);
    const double delta = 4098.0 * e0(t) / ((t + 237.3) * (t + 237.3));
    const double p = 101.3 * std::pow((293.0 - 0.0065 * z_m) / 293.0, 5.26);
    const double gamma = 0.665e-3 * p;
    const double es = 0.5 * (e0(tmax) + e0(tmin)), ea = e0(b.dew_K - 273.15);
    const double u2 = b.wind_m_s * 4.87 / std::log(67.8 * 10.0 - 5.42);
    // Extraterrestrial radiation (eq. 21) and the clear-sky radiation (eq. 37).
    const double dr = 1.0 + 0.033 * std::cos(kTwoPi * dayOfYear / 365.0);
    const double dec = 0.409 * std::sin(kTwoPi * dayOfYear / 365.0 - 1.39);
    const double ws = std::acos(-std::tan(lat_rad) * std::tan(dec));
    const double ra =
        24.0 * 60.0 / kPi * 0.0820 * dr *
        (ws * std::sin(lat_rad) * std::sin(dec) + std::cos(lat_rad) * std::cos(dec) * std::sin(ws));
    const double rso = (0.75 + 2e-5 * z_m) * ra;
    const double rs = b.ghi_J_m2 * 1e-6;  // MJ/m²
    const double rns = (1.0 - 0.23) * rs;
    const double tk4 = 0.5 * (std::pow(b.tMax_K, 4.0) + std::pow(b.tMin_K, 4.0));
    const double rnl =
        4.903e-9 * tk4 * (0.34 - 0.14 * std::sqrt(ea)) * (1.35 * std::min(1.0, rs / rso) - 0.35);
    const double rn = rns - rnl;
    return {(0.408 * delta * rn + gamma * 900.0 / (t + 273.0) * u2 * (es - ea)) /
                (delta + gamma * (1.0 + 0.34 * u2)),
            rso};
}

TEST(HeatBalanceEnergy, GrassEvaporationMatchesFao56ReferenceEvapotranspiration) {
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    const Budget b = runDay(lib.get("grass", {}), Exposure{});
    const Fao56 fao = fao56(b, 43.16856 * kRadPerDeg, 244, 150.0);  // 1 September
    const double et0 = fao.et0_mm;
    // The day's clear-sky short-wave (Ineichen–Perez on the ephemeris's Sun) against FAO-56's
    // clear-sky radiation R_so = (0.75 + 2e-5 z) R_a (eq. 37): within 10 %.
    EXPECT_NEAR(b.ghi_J_m2 * 1e-6, fao.rso_MJ_m2, 0.10 * fao.rso_MJ_m2);
    std::printf(
        "grass: evaporated %.2f mm (transpired %.2f mm) in 24 h; FAO-56 ET0 %.2f mm "
        "(Rs %.1f MJ/m2, FAO-56 Rso %.1f)\n",
        b.evaporated_kg_m2, b.transpired_kg_m2, et0, b.ghi_J_m2 * 1e-6, fao.rso_MJ_m2);
    EXPECT_NEAR(b.evaporated_kg_m2, et0, 0.35 * et0);
    // Without its stomata (no transpiration) grass would evaporate almost nothing: the test
    // can fail.
    ThermalMaterial dry = lib.get("grass", {});
    dry.surfaceResistanceDay_s_m = dry.surfaceResistanceNight_s_m = 0.0;
    EXPECT_LT(runDay(dry, Exposure{}).evaporated_kg_m2, 0.35 * et0);
}

}  // namespace
}  // namespace nvs::thermal
