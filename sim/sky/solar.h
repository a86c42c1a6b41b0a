#pragma once
// The Sun as a source above the atmosphere (docs/design.md §4.2).
//
// Spectrum: ASTM G173-03 extraterrestrial column (E-490 / Gueymard 2004 based), 350–1100 nm,
// config/spectra/astm_g173_etr_solar_350_1100nm.csv, W m⁻² nm⁻¹ at 1 au, scaled by (1 au / r)².

#include <filesystem>

#include "sim/core/photometry.h"
#include "sim/core/spectrum.h"

namespace nvs::sky {

inline constexpr double kAu_m = 149597870700.0;  // IAU 2012 exact

// Loads the solar spectrum at 1 au on the grid from <configDir>/spectra (setup; throws
// SetupError if missing).
Spectrum loadSolarSpectrum_W_m2_nm(const std::filesystem::path& configDir);

// Illuminance at normal incidence above the atmosphere at Sun distance r [lx].
double sunIlluminanceToa_lux(const Photometry& photometry, const Spectrum& solarAt1Au_W_m2_nm,
                             double sunDistance_m);

}  // namespace nvs::sky
