#pragma once
// Physical constants, SI (CODATA 2018; h, c, k are exact by the 2019 SI definition).
// Values that cross a function boundary carry their unit in their name (docs/design.md §3).

namespace nvs {

inline constexpr double kPi = 3.14159265358979323846;
inline constexpr double kTwoPi = 2.0 * kPi;
inline constexpr double kDegPerRad = 180.0 / kPi;
inline constexpr double kRadPerDeg = kPi / 180.0;

inline constexpr double kPlanck_J_s = 6.62607015e-34;
inline constexpr double kSpeedOfLight_m_s = 299792458.0;
inline constexpr double kElectronCharge_C = 1.602176634e-19;  // exact (SI 2019)
inline constexpr double kBoltzmann_J_K = 1.380649e-23;

// Derived constants, quoted (not computed) so tests can hold the code against them.
// CODATA 2018: sigma = 5.670374419e-8 W m^-2 K^-4, b = 2.897771955e-3 m K.
inline constexpr double kStefanBoltzmann_W_m2_K4 = 5.670374419e-8;
inline constexpr double kWienDisplacement_m_K = 2.897771955e-3;

// Maximum luminous efficacy of photopic vision, K_m (SI definition of the candela; the CIE
// quotes 683.002 lm/W at 555 nm, which rounds to this).
inline constexpr double kLuminousEfficacy_lm_W = 683.0;

inline constexpr double kNmPerM = 1e9;
inline constexpr double kMPerNm = 1e-9;

}  // namespace nvs
