#pragma once
// Water vapour from the weather record: saturation vapour pressure over water by the Magnus form
// with the coefficients of Alduchov & Eskridge (1996), "Improved Magnus form approximation of
// saturation vapor pressure", J. Appl. Meteor. 35(4), 601–609 (their AERK fit, −40…50 °C,
// relative error < 0.4 %):
//
//   e_s(t) = 610.94 Pa · exp(17.625 t / (t + 243.04 °C)),   t in °C
//
// The vapour pressure is e = e_s(T_dew), or e = RH · e_s(T_air); the vapour density (ideal gas)
// is ρ_w = e M_w / (R T).  Setup-time functions: bad input throws SetupError.

namespace nvs::lwir {

inline constexpr double kGasConstant_J_mol_K = 8.314462618;  // CODATA 2018
inline constexpr double kMolarMassWater_kg_mol = 18.01528e-3;
inline constexpr double kMolarMassCo2_kg_mol = 44.0095e-3;
inline constexpr double kMolarMassO3_kg_mol = 47.9982e-3;
inline constexpr double kStandardPressure_Pa = 101325.0;
inline constexpr double kAvogadro_mol = 6.02214076e23;

// Saturation vapour pressure over liquid water [Pa] at temperature T [K].
double saturationVapourPressure_Pa(double temperature_K);
// Vapour pressure [Pa] from the dew point [K].
double vapourPressureFromDewPoint_Pa(double dewPoint_K);
// Vapour pressure [Pa] from relative humidity (0–1) and air temperature [K].
double vapourPressureFromRelativeHumidity_Pa(double relativeHumidity, double airTemperature_K);
// Dew point [K] of a vapour pressure [Pa] (the Magnus form inverted).
double dewPointFromVapourPressure_K(double vapourPressure_Pa);
// Vapour density [kg m⁻³] of a vapour pressure at a temperature.
double vapourDensity_kg_m3(double vapourPressure_Pa, double temperature_K);

}  // namespace nvs::lwir
