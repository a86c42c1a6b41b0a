#pragma once
// Surface temperatures of a scene's surface classes over a time range (docs/thermal.md §4–5).
//
// A surface class is (material, orientation, sky-view factor, Sun-shadow history). Every class
// is solved by its own SurfaceSolver, driven by one forcing series (Sun, sky, air) sampled
// every dt_s from the start of the weather file. The profile starts uniform at the first day's
// mean air temperature and is spun up by repeating the first 24 h of forcing until the whole
// profile at the end of the day is within spinupTolerance_K of its start (at most
// maxSpinupDays), then advanced to the end of the range. The result is a table of surface
// temperatures every dt_s from tableStart_s to tableEnd_s, one row per class; sampling it is
// linear interpolation without allocation (per frame). Results are cached by an FNV-1a hash of
// every input in a folder the caller passes (nothing under sim/ reads the environment).
//
// Parameter table (name, unit, default, meaning):
//   dt_s               s    60     step of the solver and of the table
//   spinupTolerance_K  K    0.01   periodicity of the spun-up first day
//   maxSpinupDays      –    60     limit of the spin-up

#include <filesystem>
#include <string>
#include <vector>

#include "sim/astro/ephemeris.h"
#include "sim/thermal/surface_solver.h"

namespace nvs::thermal {

struct SurfaceClass {
    std::string name;
    ThermalMaterial material;  // must have thermal properties
    Exposure exposure;
    // Sun-shadow history: sunlit fraction of the class against time (POSIX UTC s), linear,
    // clamped outside; empty: always sunlit (1).
    std::vector<double> sunlitTimes_s;
    std::vector<double> sunlitFraction;
};

struct HeatBalanceParams {
    ForcingParams forcing;
    GridParams grid;
    double dt_s = 60.0;
    double spinupTolerance_K = 0.01;
    int maxSpinupDays = 60;
};

class SurfaceTemperatureTable {
  public:
    SurfaceTemperatureTable() = default;
    SurfaceTemperatureTable(std::size_t classes, std::size_t samples, double t0_s, double dt_s)
        : classes_(classes),
          samples_(samples),
          t0_s_(t0_s),
          dt_s_(dt_s),
          T_K_(classes * samples, 0.0f) {}

    // Surface temperature of class `cls` at t_s, linear in time, clamped to the range.
    // Per frame: no allocation, no throw.
    double at(std::size_t cls, double t_s) const noexcept;
    float& sample(std::size_t cls, std::size_t i) { return T_K_[cls * samples_ + i]; }
    float sample(std::size_t cls, std::size_t i) const { return T_K_[cls * samples_ + i]; }
    std::size_t classes() const { return classes_; }
    std::size_t samples() const { return samples_; }
    double t0_s() const { return t0_s_; }
    double dt_s() const { return dt_s_; }
    std::size_t bytes() const { return T_K_.size() * sizeof(float); }
    const std::vector<float>& data() const { return T_K_; }
    std::vector<float>& data() { return T_K_; }

  private:
    std::size_t classes_ = 0, samples_ = 0;
    double t0_s_ = 0.0, dt_s_ = 1.0;
    std::vector<float> T_K_;
};

// What a solve reports besides the table.
struct HeatBalanceReport {
    std::vector<int> spinupDays;         // per class
    std::vector<double> dew_kg_m2;       // per class: water held at the end (empty from the cache)
    std::uint64_t unconvergedSteps = 0;  // all classes (SurfaceSolver::unconvergedSteps)
    std::size_t stateBytes = 0;          // solvers + forcing series + table
    bool fromCache = false;
    std::filesystem::path cacheFile;  // empty without a cache folder
};

// Solves every class (see above). Throws SetupError when the weather does not cover
// [tableStart_s − 24 h, tableEnd_s] (naming its file), or on bad classes. `cacheDir` empty:
// no cache; otherwise it must exist, and the table is read from or written to
// cacheDir/thermal-<hash>.bin.
SurfaceTemperatureTable solveHeatBalance(const std::vector<SurfaceClass>& classes,
                                         const WeatherSeries& weather, const astro::Site& site,
                                         const HeatBalanceParams& p, double tableStart_s,
                                         double tableEnd_s,
                                         const std::filesystem::path& cacheDir = {},
                                         HeatBalanceReport* report = nullptr);

// One class's surface temperature at t_s: a table of that one instant (same spin-up, same
// cache). Set-up code (it solves); per frame use the table.
double surfaceTemperature_K(const SurfaceClass& surfaceClass, const WeatherSeries& weather,
                            const astro::Site& site, const HeatBalanceParams& p, double t_s,
                            const std::filesystem::path& cacheDir = {});

// The cache key of a solve (FNV-1a over every input, with a format version).
std::uint64_t heatBalanceKey(const std::vector<SurfaceClass>& classes, const WeatherSeries& weather,
                             const astro::Site& site, const HeatBalanceParams& p,
                             double tableStart_s, double tableEnd_s);

// Sunlit fraction of a class at t_s (linear in its history, 1 when it has none).
double sunlitAt(const SurfaceClass& c, double t_s) noexcept;

}  // namespace nvs::thermal
