#pragma once
// What drives a surface's heat balance (docs/thermal.md §3): the Sun, the sky's long-wave
// down-welling, the air (convection), for one instant.
//
// Parameter table (name, unit, default, meaning, source):
//   linkeTurbidity   –    3.0  Linke turbidity of the clear sky (rural mid-latitude
//                              summer air, 3–3.5: Ineichen & Perez 2002, Fig. 4)
//   lapseRate_K_m    K/m  0.0065  cloud base temperature = air − Γ·base (ICAO standard
//                              atmosphere, ISO 2533:1975)

#include "sim/astro/ephemeris.h"
#include "sim/thermal/weather.h"

namespace nvs::thermal {

struct ForcingParams {
    double linkeTurbidity = 3.0;
    double lapseRate_K_m = 0.0065;
    double siteAltitude_m = 150.0;  // solveHeatBalance sets it from the site's height
};

struct SolarIrradiance {
    double ghi_W_m2 = 0.0;  // global horizontal
    double dni_W_m2 = 0.0;  // direct normal
    double dhi_W_m2 = 0.0;  // diffuse horizontal
};

// Relative optical airmass, Kasten & Young (1989), "Revised optical air mass tables and
// approximation formula", Applied Optics 28(22), 4735–4738:
//   m = 1/(cos z + 0.50572 (96.07995° − z)^−1.6364).
double airmassKastenYoung(double zenith_rad) noexcept;

// Clear-sky broadband irradiance, Ineichen & Perez (2002), "A new airmass independent
// formulation for the Linke turbidity coefficient", Solar Energy 73(3), 151–157, eqs. 1–2 and
// the direct-beam bound of its erratum (Solar Energy 73, 2002), for the apparent zenith z, the
// Sun–Earth distance and the site altitude h:
//   GHI = c_g1 I₀ cos z exp(−c_g2 m (f_h1 + f_h2 (T_L − 1))),
//   c_g1 = 5.09e−5 h + 0.868, c_g2 = 3.92e−5 h + 0.0387, f_h1 = e^{−h/8000}, f_h2 = e^{−h/1250},
//   DNI = min(b I₀ exp(−0.09 m (T_L − 1)), GHI (1 − (0.1 − 0.2 e^{−T_L})/(0.1 + 0.882/f_h1))/cos
//   z), b = 0.664 + 0.163/f_h1,  DHI = GHI − DNI cos z,
// with I₀ = 1361 W/m² (Kopp & Lean 2011, Geophys. Res. Lett. 38, L01706) × (1 au / r)² and m
// the Kasten–Young airmass times e^{−h/8434.5} (pressure). Zero with the Sun below the horizon.
SolarIrradiance clearSkySolar(double apparentZenith_rad, double sunDistance_m,
                              double siteAltitude_m, double linkeTurbidity) noexcept;

// Cloud attenuation, Kasten & Czeplak (1980), "Solar and terrestrial radiation dependent on the
// amount and type of cloud", Solar Energy 24, 177–189, with N/8 the cloud fraction c:
//   G = G_clear (1 − 0.75 c^3.4),  D/G = 0.3 + 0.7 c²,  beam = G − D.
SolarIrradiance cloudySolar(const SolarIrradiance& clear, double cloudFraction,
                            double cosZenith) noexcept;

// Water vapour pressure at the dew point, Magnus form with the coefficients of Alduchov &
// Eskridge (1996), "Improved Magnus form approximation of saturation vapor pressure", J. Appl.
// Meteor. 35, 601–609: e = 6.1094 exp(17.625 t/(t + 243.04)) hPa, t in °C.
double vapourPressure_hPa(double dewPoint_K) noexcept;

// Clear-sky broadband emissivity, Brutsaert (1975), "On a derivable formula for long-wave
// radiation from clear skies", Water Resources Research 11(5), 742–744:
//   ε_clr = 1.24 (e/T_a)^{1/7},  e in hPa, T_a in K.
double clearSkyEmissivity(double air_K, double dewPoint_K) noexcept;

// Broadband long-wave irradiance from the whole sky on a horizontal surface [W/m²]:
//   L↓ = ε_clr σT_a⁴ + c (1 − ε_clr) σT_c⁴,  T_c = T_a − Γ·base.
// The cloud adds its own emission, as a blackbody at its base temperature, through the part of
// the spectrum the clear air below it leaves open (weight 1 − ε_clr): the structure of Kimball,
// Idso & Aase (1982), "A model of thermal radiation from partly cloudy and overcast skies",
// Water Resources Research 18(4), 931–936, with their 8–14 µm window transmittance and band
// fraction replaced by the clear sky's own deficit 1 − ε_clr. A low overcast (T_c → T_a) gives
// L↓ → σT_a⁴, as Crawford & Duchon (1999, J. Appl. Meteor. 38, 474–480: ε = c + (1 − c) ε_clr)
// do (tests compare the two).
double longwaveDown_W_m2(const WeatherSample& w, double lapseRate_K_m) noexcept;

// The sky's long-wave radiance is not isotropic: it is least at the zenith and nearly that of a
// blackbody at the air temperature at the horizon. A grey isothermal slab gives its directional
// emissivity (Granqvist & Hjortsberg 1981, "Radiative cooling to low temperatures: general
// considerations and application to selectively emitting SiO films", J. Appl. Phys. 52(6),
// 4205–4220):  ε(θ) = 1 − (1 − ε₀)^{1/cos θ},
// with ε₀ fitted so that its horizontal hemispherical mean 2∫ε(θ) cos θ sin θ dθ equals the
// whole sky's effective emissivity ε_eff = L↓/σT_a⁴ (clouds included). A plane tilted by β sees
// the sky in front of it weighted by cos γ (γ from its normal); the ratio of that weighted mean
// to the horizontal one scales L↓ for the plane's sky part: 1 for β = 0, above 1 for walls,
// which see more of the low, warm sky.
class TiltedSky {
  public:
    explicit TiltedSky(double tilt_rad = 0.0);
    // The ratio for the sky's effective emissivity (clamped to [0.3, 1]); per step: no
    // allocation, no throw.
    double ratio(double effectiveEmissivity) const noexcept;

    static constexpr int kTable = 71;  // ε_eff from 0.3 to 1.0 by 0.01

  private:
    double table_[kTable] = {};
};
// The slab's horizontal hemispherical emissivity for a zenith emissivity ε₀, and its inverse.
double slabHemisphericalEmissivity(double zenithEmissivity) noexcept;
double slabZenithEmissivity(double hemisphericalEmissivity) noexcept;
// The cos γ-weighted mean emissivity of the sky in front of a plane tilted by β.
double slabMeanEmissivityOnTilt(double zenithEmissivity, double tilt_rad) noexcept;

// Exterior convection coefficient [W/m²K], the DOE-2 model (ASHRAE Handbook of Fundamentals;
// EnergyPlus Engineering Reference, "Exterior convection: DOE-2 model", after Walton 1983,
// "Thermal Analysis Research Program reference manual", NBSIR 83-2655):
//   h = h_n + R_f (h_glass − h_n),  h_glass = √(h_n² + (a V^b)²),  a = 3.26, b = 0.89 (windward),
//   natural h_n (TARP): vertical 1.31|ΔT|^{1/3}; tilted, unstable (heat flowing up)
//   9.482|ΔT|^{1/3}/(7.238 − |cos Σ|); stable (a surface facing up colder than the air: a clear
//   night) 1.810|ΔT|^{1/3}/(1.382 + |cos Σ|); ΔT = T_s − T_a, Σ the tilt from horizontal
//   facing up. V is the 10-m wind of the weather file, taken at the surface.
double convectionCoefficient_W_m2K(double wind_m_s, double surface_K, double air_K, double cosTilt,
                                   double roughnessMultiplier) noexcept;

// Latent heat: dew condensing on a surface below the dew point, the evaporation of what it holds,
// and transpiration, by the heat–mass transfer analogy (Chilton–Colburn; Incropera et al.,
// "Fundamentals of Heat and Mass Transfer", 6th ed., §6.7.2):
//   h_m = h_c / (ρ c_p Le^{2/3}),  q_lat = L_v g (ρ_v,air − ρ_v,sat(T_s)),  ρ_v = e/(R_v T),
// with g = h_m for a wet or dewy surface and g = 1/(1/h_m + r_s) through leaves' stomata
// (surface resistance r_s, the Penman–Monteith form); ρ = 101325 Pa/(R_d T_a),
// c_p = 1007 J/kgK, Le = 0.87 (air–water vapour near 298 K: α = 22.5e-6 over D = 26e-6 m²/s,
// Incropera Tables A.4 and A.8), L_v = 2.45e6 J/kg (Table A.6, 293 K), R_v = 461.5 and
// R_d = 287.05 J/kgK; e_sat by the Magnus form above (over water).
// Positive: condensation, heat into the surface.
inline constexpr double kLatentHeat_J_kg = 2.45e6;
double massTransfer_m_s(double hc_W_m2K, double air_K) noexcept;
double latentFlux_W_m2(double conductance_m_s, double surface_K, double air_K,
                       double dewPoint_K) noexcept;
// Of a wet surface (g = h_m): dew while negative evaporation is not capped by the water held.
double dewFlux_W_m2(double hc_W_m2K, double surface_K, double air_K, double dewPoint_K) noexcept;

// One instant's forcing, shared by every surface class.
struct ForcingSample {
    WeatherSample weather;
    SolarIrradiance sun;             // after cloud attenuation
    double sunAz_rad = 0.0;          // from north through east
    double sunAlt_rad = 0.0;         // apparent
    double longwaveDown_W_m2 = 0.0;  // whole sky, horizontal
};

// The forcing at t_s (POSIX UTC seconds): the Sun from the ephemeris, the weather interpolated.
// `t0` is the AstroTime of `t0_s`. Per step: no allocation, no throw.
ForcingSample forcingAt(const astro::Ephemeris& eph, const astro::AstroTime& t0, double t0_s,
                        const WeatherSeries& weather, const ForcingParams& p, double t_s) noexcept;

// Orientation of a surface class: its normal's tilt from the zenith and azimuth from north
// through east.
struct Orientation {
    double tilt_rad = 0.0;
    double azimuth_rad = 0.0;
};

// Short-wave irradiance on the surface [W/m²]: beam on the plane times the sunlit fraction,
// isotropic diffuse sky over the sky-view factor F, ground reflection over 1 − F:
//   E = DNI max(0, cos θ_i) f_sun + DHI F + GHI ρ_g (1 − F).
double planeShortwave_W_m2(const ForcingSample& f, const Orientation& o, double skyView,
                           double sunlitFraction, double groundAlbedo) noexcept;

}  // namespace nvs::thermal
