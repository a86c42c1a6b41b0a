#pragma once
// Bright stars seen directly (docs/design.md §4.4: "lamps, Moon and bright stars visible in view
// with their true radiance"). A small catalogue (config/stars/bright_stars.csv: ICRS right
// ascension and declination, Johnson V), placed each frame by astro::Ephemeris::stars; frameStars
// turns the placed stars into the frame's sky message (msg::FrameStar), which the renderer draws
// as point sources: the irradiance a star gives at the lens, spread over the pixel it falls in.
//
// Illuminance above the atmosphere from the V magnitude (Allen's Astrophysical Quantities, 4th
// ed., §15.1: a star of V = 0 gives 2.54·10⁻⁶ lx outside the atmosphere):
//     E_v = 10^(−0.4 (V + 13.99))  [lx]
// In a camera band with weight w(λ) the star's spectrum is taken as a blackbody at T (5800 K:
// a solar-type star; the catalogue's stars range from O to M types, so the band value of a
// single star is good to a factor that depends on its colour — about ±40 % between 3500 and
// 10000 K in the S-25 band — which the catalogue does not carry):
//     E_b = E_v · ∫ B_T(λ) w(λ) dλ / (K_m ∫ B_T(λ) V(λ) dλ)
// and is attenuated by the atmosphere's band direct transmittance at the star's zenith angle.

#include <array>
#include <filesystem>
#include <string>
#include <vector>

#include "sim/core/photometry.h"
#include "sim/core/spectrum.h"
#include "sim/msg/sky.h"
#include "sim/sky/atmosphere_table.h"

namespace nvs::sky {

struct StarCatalog {
    std::string file;
    std::vector<std::string> name;
    std::vector<double> ra_rad, dec_rad, vMag;
    std::size_t size() const { return name.size(); }
};

// <configDir>/stars/bright_stars.csv.
std::filesystem::path starCatalogPath(const std::filesystem::path& configDir);

// Reads a catalogue (columns name, ra_deg, dec_deg, v_mag; a '# source:' line required).
// Throws SetupError naming file:line for a missing column, a value out of range or no source.
StarCatalog loadStarCatalog(const std::filesystem::path& path);

// E_v above the atmosphere [lx] of a star of visual magnitude vMag.
double starIlluminanceToa_lx(double vMag);

// Band value per lux for a blackbody spectrum at temperature_K: ∫B w dλ / (K_m ∫B V dλ).
double bandPerLux(const Photometry& photometry, const Spectrum& weight, double temperature_K);

inline constexpr double kStarTemperature_K = 5800.0;

// The stars of `catalog` above the horizon in the frame's sky message: sky->stars[0 ..
// sky->starCount) get the direction (ENU) and the band irradiance at the lens
//     E_b = E_v(V) · bandPerLux[b] · T_direct,b(z),  z = 90° − altitude,
// T_direct from `table`'s band tableBand[b]. az_rad, alt_rad: each catalogue star's place this
// frame (astro::Ephemeris::stars). At most msg::kMaxStars stars (the catalogue is checked at
// setup). No allocation, no throw.
void frameStars(const StarCatalog& catalog, const double* az_rad, const double* alt_rad,
                const std::array<double, msg::kBands>& bandPerLux, const AtmosphereTable& table,
                const std::array<int, msg::kBands>& tableBand, msg::FrameSky* sky) noexcept;

}  // namespace nvs::sky
