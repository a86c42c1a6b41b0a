#pragma once
// The LWIR table (docs/lwir.md §5): every thermal-band atmosphere term the renderer needs per
// pixel, for one camera band and one night's air, built once, cached on disk like the visible
// table (sim/sky/atmosphere_table.h), and interpolated without allocation:
//
//   path(r)              τ_band(r), L_path(r) of a horizontal path, r = 1 m … 20 km, 96 log
//                        steps (τ and L interpolated linearly in ln r; below 1 m linearly
//                        in r to τ = 1, L = 0 at r = 0; beyond 20 km the 20 km value)
//   skyRadiance(θ)       sky band radiance against zenith angle, 0–90° every 1°
//   blackbody(T)         B_band(T), 150–400 K every 0.5 K; brightnessTemperature(L) its inverse
//   apertureRadiance     τ(r) [ε B(T) + (1 − ε) L_reflected] + L_path(r)
//   skyDiffuseRadiance   E_sky/π, the sky a horizontal Lambertian surface reflects
//
// Cache file: <DataDirs::cache>/lwir-<key>.bin, key = hash of the coefficients, the band, the
// air, the sky and the format version; a stale, truncated or corrupt file is rebuilt.

#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "sim/core/paths.h"
#include "sim/lwir/absorption.h"
#include "sim/lwir/band.h"
#include "sim/lwir/sky.h"

namespace nvs::lwir {

struct LwirTableInputs {
    AirState air;   // screen-level air for horizontal paths
    SkyParams sky;  // the sky; its air temperature, vapour and pressure should match `air`
    BandResponse band = BandResponse::flat(7.5, 13.5);
    // Also tabulate slant paths from a raised sensor (about 1.3 s more to build).
    bool slantPaths = false;

    // The inputs of one night from its weather: screen-level air temperature and dew point,
    // station pressure, cloud fraction (0–1) and base; the other sky parameters default.
    // A dew point above the air temperature (by more than 0.1 K) is a SetupError.
    static LwirTableInputs fromWeather(double airTemperature_K, double dewPoint_K,
                                       double pressure_Pa, double cloudFraction, double cloudBase_m,
                                       const BandResponse& band);
};

class LwirTable {
  public:
    static constexpr int kRanges = 97;
    static constexpr double kMinRange_m = 1.0;
    static constexpr double kMaxRange_m = 20000.0;
    static constexpr int kZeniths = 91;
    static constexpr int kTemperatures = 501;
    static constexpr double kMinTemperature_K = 150.0;
    static constexpr double kTemperatureStep_K = 0.5;
    static constexpr std::uint32_t kFormatVersion = 2;
    // Slant paths: sensor heights [m] (linear between), view zenith 0–180° every 3°, the
    // same ranges.
    static constexpr int kSlantHeights = 8;
    static constexpr double kSlantHeights_m[kSlantHeights] = {0, 2, 10, 30, 100, 300, 1000, 3000};
    static constexpr int kSlantZeniths = 61;

    // Builds the table (about 70 ms; 1.4 s with slant paths) with the coefficients under
    // configDir.
    static LwirTable build(const LwirTableInputs& inputs, const std::filesystem::path& configDir);
    // Loads the cached table from dirs.cache or builds and caches it (empty cache: no file).
    static LwirTable loadOrBuild(const LwirTableInputs& inputs, const DataDirs& dirs,
                                 bool* rebuilt = nullptr);
    static std::string cacheKey(const LwirTableInputs& inputs,
                                const std::filesystem::path& configDir);

    // Per-pixel lookups: no allocation, no exceptions.
    PathBand path(double range_m) const;
    // τ_band and L_path from a sensor `sensorHeight_m` above the ground (0–3 km, clamped) at
    // view zenith θ (0 up, 90° horizontal, 180° down) over `range_m`, through the layered
    // atmosphere of the sky (docs/lwir.md §5); the horizontal path(range_m) if the table was
    // built without slant paths.
    PathBand slantPath(double sensorHeight_m, double viewZenith_rad, double range_m) const;
    bool hasSlantPaths() const { return !slantTau_.empty(); }
    double skyRadiance_W_m2_sr(double zenith_rad) const;
    double blackbody_W_m2_sr(double temperature_K) const;
    double brightnessTemperature_K(double radiance_W_m2_sr) const;
    double apertureRadiance_W_m2_sr(double emissivity, double temperature_K,
                                    double reflected_W_m2_sr, double range_m) const {
        const PathBand p = path(range_m);
        return p.transmittance * (emissivity * blackbody_W_m2_sr(temperature_K) +
                                  (1.0 - emissivity) * reflected_W_m2_sr) +
               p.pathRadiance_W_m2_sr;
    }
    // Hemispheric band emittance of the sky (the table's angles), and the sky radiance a
    // horizontal diffuse (Lambertian) surface reflects, E_sky/π = ε_sky B_band(T_air).
    double skyEmittance() const { return skyEmittance_; }
    double skyDiffuseRadiance_W_m2_sr() const { return skyDiffuse_; }
    // The same for a plane tilted by β (0 up, π/2 a wall, π down), the sky part only (the
    // ground's share is the renderer's): every 5°, interpolated.
    static constexpr int kTilts = 37;
    double tiltedSkyRadiance_W_m2_sr(double tilt_rad) const;

    void save(const std::filesystem::path& file, std::uint64_t key) const;
    // Replaces this table by the file's if it is usable; else says why and leaves it.
    bool load(const std::filesystem::path& file, std::uint64_t key, std::string* why);

  private:
    // Only build() and loadOrBuild() make tables, so no lookup ever meets an empty one.
    LwirTable() = default;
    // Grid steps per octave of range, (kRanges − 1)/log₂(max/min): set once, not per lookup.
    double rangeScale_ = (kRanges - 1) / std::log2(kMaxRange_m / kMinRange_m);
    std::vector<double> tau_;     // [kRanges]
    std::vector<double> path_;    // [kRanges]
    std::vector<double> sky_;     // [kZeniths]
    std::vector<double> planck_;  // [kTemperatures]
    double skyEmittance_ = 0.0;
    double skyDiffuse_ = 0.0;
    std::vector<double> tilted_;    // [kTilts]
    std::vector<double> slantTau_;  // [height][zenith][range], or empty
    std::vector<double> slantPath_;
};

}  // namespace nvs::lwir
