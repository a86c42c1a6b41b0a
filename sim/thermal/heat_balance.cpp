#include "sim/thermal/heat_balance.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>

#include "sim/core/fnv.h"
#include "sim/core/input_file.h"
#include "sim/core/output_file.h"

namespace nvs::thermal {

double SurfaceTemperatureTable::at(std::size_t cls, double t_s) const noexcept {
    const double u = std::clamp((t_s - t0_s_) / dt_s_, 0.0, static_cast<double>(samples_ - 1));
    const std::size_t i = std::min(static_cast<std::size_t>(u), samples_ - 1);
    const std::size_t j = std::min(i + 1, samples_ - 1);
    const double f = u - static_cast<double>(i);
    const float* row = T_K_.data() + cls * samples_;
    const double a = static_cast<double>(row[i]), b = static_cast<double>(row[j]);
    return a + f * (b - a);
}

double sunlitAt(const SurfaceClass& c, double t_s) noexcept {
    const std::vector<double>& t = c.sunlitTimes_s;
    if (t.empty()) return 1.0;
    if (t_s <= t.front()) return c.sunlitFraction.front();
    if (t_s >= t.back()) return c.sunlitFraction.back();
    const std::size_t i =
        static_cast<std::size_t>(std::upper_bound(t.begin(), t.end(), t_s) - t.begin());
    const double f = (t_s - t[i - 1]) / (t[i] - t[i - 1]);
    return c.sunlitFraction[i - 1] + f * (c.sunlitFraction[i] - c.sunlitFraction[i - 1]);
}

namespace {

constexpr std::uint64_t kFormatVersion = 3;
constexpr char kMagic[8] = {'N', 'V', 'S', 'T', 'H', 'M', '1', '\0'};

// POSIX seconds → UTC calendar (Hinnant's civil_from_days).
astro::CalendarInstant calendarOf(double t_s) {
    const double dayF = std::floor(t_s / 86400.0);
    const long z = static_cast<long>(dayF) + 719468;
    const long era = (z >= 0 ? z : z - 146096) / 146097;
    const long doe = z - era * 146097;
    const long yoe = (doe - doe / 1460 + doe / 36524 - doe / 146096) / 365;
    const long doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    const long mp = (5 * doy + 2) / 153;
    astro::CalendarInstant c;
    c.day = static_cast<int>(doy - (153 * mp + 2) / 5 + 1);
    c.month = static_cast<int>(mp < 10 ? mp + 3 : mp - 9);
    c.year = static_cast<int>(yoe + era * 400 + (c.month <= 2 ? 1 : 0));
    const double sec = t_s - dayF * 86400.0;
    c.hour = static_cast<int>(sec / 3600.0);
    c.minute = static_cast<int>((sec - c.hour * 3600.0) / 60.0);
    c.second = sec - c.hour * 3600.0 - c.minute * 60.0;
    return c;
}

template <class T>
void hashValue(Fnv1a& h, const T& v) {
    h.bytes(&v, sizeof v);
}
void hashVector(Fnv1a& h, const std::vector<double>& v) {
    hashValue(h, v.size());
    if (!v.empty()) h.bytes(v.data(), v.size() * sizeof(double));
}

void hashMaterial(Fnv1a& h, const ThermalMaterial& m) {
    h.bytes(m.name.data(), m.name.size());
    for (double v : {m.emissivityNormal, m.solarAbsorptance, m.roughnessMultiplier,
                     m.backTemperature_K, m.backAirOffset_K, m.backFilm_W_m2K, m.backFlux_W_m2,
                     m.surfaceTemperature_K, m.index_n, m.emissivityHemispherical})
        hashValue(h, v);
    hashValue(h, static_cast<int>(m.angular));
    hashValue(h, static_cast<int>(m.back));
    hashValue(h, m.backFollowsAir);
    hashValue(h, m.collectsDew);
    hashValue(h, m.surfaceResistanceDay_s_m);
    hashValue(h, m.surfaceResistanceNight_s_m);
    for (const Layer& l : m.layers)
        for (double v : {l.thickness_m, l.conductivity_W_mK, l.density_kg_m3, l.specificHeat_J_kgK})
            hashValue(h, v);
}

// The whole forcing series, every dt_s from t0_s over n steps (set-up: it allocates).
std::vector<ForcingSample> forcingSeries(const WeatherSeries& w, const astro::Site& site,
                                         const ForcingParams& fp, double t0_s, double dt_s,
                                         std::size_t n) {
    const astro::Ephemeris eph(site);
    const astro::AstroTime at0 = astro::astroTimeFromUtc(calendarOf(t0_s), "weather start");
    std::vector<ForcingSample> f(n);
    for (std::size_t i = 0; i < n; ++i)
        f[i] = forcingAt(eph, at0, t0_s, w, fp, t0_s + static_cast<double>(i) * dt_s);
    return f;
}

// Repeats the first day (steps 1..day) until the profile is periodic; returns the days used.
int spinUp(SurfaceSolver& s, const SurfaceClass& c, const std::vector<ForcingSample>& f,
           std::size_t day, double t0_s, const HeatBalanceParams& p) {
    std::vector<double> before;
    for (int d = 1; d <= p.maxSpinupDays; ++d) {
        before = s.temperatures_K();
        for (std::size_t i = 1; i <= day; ++i)
            s.step(f[i], sunlitAt(c, t0_s + static_cast<double>(i) * p.dt_s), p.dt_s);
        double moved = 0.0;
        for (std::size_t k = 0; k < before.size(); ++k)
            moved = std::max(moved, std::abs(s.temperatures_K()[k] - before[k]));
        if (moved < p.spinupTolerance_K) return d;
    }
    return p.maxSpinupDays;
}

bool readCache(const std::filesystem::path& file, std::uint64_t key,
               SurfaceTemperatureTable& table) {
    if (!pathExists(file)) return false;
    std::ifstream in(file, std::ios::binary);
    char magic[8] = {};
    std::uint64_t k = 0, nc = 0, ns = 0;
    double t0 = 0.0, dt = 0.0;
    in.read(magic, 8);
    in.read(reinterpret_cast<char*>(&k), 8);
    in.read(reinterpret_cast<char*>(&nc), 8);
    in.read(reinterpret_cast<char*>(&ns), 8);
    in.read(reinterpret_cast<char*>(&t0), 8);
    in.read(reinterpret_cast<char*>(&dt), 8);
    if (!in || std::memcmp(magic, kMagic, 8) != 0 || k != key || nc != table.classes() ||
        ns != table.samples())
        return false;
    in.read(reinterpret_cast<char*>(table.data().data()),
            static_cast<std::streamsize>(table.bytes()));
    return static_cast<bool>(in);
}

void writeCache(const std::filesystem::path& file, std::uint64_t key,
                const SurfaceTemperatureTable& table) {
    OutputFiles out;
    out.addFile("thermal cache", file);
    out.writeWith(file, [&](const std::filesystem::path& temp) {
        std::ofstream o(temp, std::ios::binary);
        const std::uint64_t nc = table.classes(), ns = table.samples();
        const double t0 = table.t0_s(), dt = table.dt_s();
        o.write(kMagic, 8);
        o.write(reinterpret_cast<const char*>(&key), 8);
        o.write(reinterpret_cast<const char*>(&nc), 8);
        o.write(reinterpret_cast<const char*>(&ns), 8);
        o.write(reinterpret_cast<const char*>(&t0), 8);
        o.write(reinterpret_cast<const char*>(&dt), 8);
        o.write(reinterpret_cast<const char*>(table.data().data()),
                static_cast<std::streamsize>(table.bytes()));
        if (!o) throw std::runtime_error("short write");
    });
    out.commit();
}

void checkInputs(const std::vector<SurfaceClass>& classes, const WeatherSeries& w,
                 const HeatBalanceParams& p, double t0_s, double t1_s) {
    const std::string where = w.file().empty() ? std::string("weather") : w.file();
    if (!(p.dt_s > 0.0 && p.dt_s <= 3600.0))
        throw SetupError("heat balance: dt_s outside (0, 3600]");
    if (!(t1_s >= t0_s)) throw SetupError("heat balance: the table ends before it starts");
    if (w.start_s() > t0_s - 86400.0)
        throw SetupError(where + ": the weather must start 24 h or more before the scene (" +
                         std::to_string((t0_s - w.start_s()) / 3600.0) + " h given)");
    if (w.end_s() < t1_s) throw SetupError(where + ": the weather ends before the scene does");
    for (const SurfaceClass& c : classes) {
        if (!c.material.hasThermal())
            throw SetupError(c.material.loc, "surface class '" + c.name + "': material '" +
                                                 c.material.name + "' has no thermal layers");
        if (c.sunlitTimes_s.size() != c.sunlitFraction.size())
            throw SetupError("surface class '" + c.name + "': one sunlit fraction per time");
        for (std::size_t i = 0; i < c.sunlitTimes_s.size(); ++i) {
            if (i > 0 && !(c.sunlitTimes_s[i] > c.sunlitTimes_s[i - 1]))
                throw SetupError("surface class '" + c.name + "': shadow history not increasing");
            if (!(c.sunlitFraction[i] >= 0.0 && c.sunlitFraction[i] <= 1.0))
                throw SetupError("surface class '" + c.name + "': sunlit fraction outside [0, 1]");
        }
    }
}

}  // namespace

std::uint64_t heatBalanceKey(const std::vector<SurfaceClass>& classes, const WeatherSeries& weather,
                             const astro::Site& site, const HeatBalanceParams& p,
                             double tableStart_s, double tableEnd_s) {
    Fnv1a h;
    hashValue(h, kFormatVersion);
    for (const SurfaceClass& c : classes) {
        hashMaterial(h, c.material);
        const Exposure& e = c.exposure;
        for (double v : {e.orientation.tilt_rad, e.orientation.azimuth_rad, e.skyView,
                         e.groundAlbedo, e.deepTemperature_K})
            hashValue(h, v);
        hashVector(h, c.sunlitTimes_s);
        hashVector(h, c.sunlitFraction);
    }
    hashVector(h, weather.times_s());
    for (const WeatherSample& s : weather.samples())
        for (double v : {s.air_K, s.dewPoint_K, s.wind_m_s, s.cloudFraction, s.cloudBase_m})
            hashValue(h, v);
    for (double v :
         {site.lat_deg, site.lon_deg, site.height_m, site.pressure_hPa, site.temperature_C,
          site.relativeHumidity, p.forcing.linkeTurbidity, p.forcing.lapseRate_K_m,
          p.forcing.siteAltitude_m, p.grid.firstCell_m, p.grid.growth, p.grid.maxCell_m, p.dt_s,
          p.spinupTolerance_K, tableStart_s, tableEnd_s})
        hashValue(h, v);
    hashValue(h, p.maxSpinupDays);
    return h.h;
}

SurfaceTemperatureTable solveHeatBalance(const std::vector<SurfaceClass>& classes,
                                         const WeatherSeries& weather, const astro::Site& site,
                                         const HeatBalanceParams& p, double tableStart_s,
                                         double tableEnd_s, const std::filesystem::path& cacheDir,
                                         HeatBalanceReport* report) {
    checkInputs(classes, weather, p, tableStart_s, tableEnd_s);
    const double t0 = weather.start_s();
    // The table's samples cover [tableStart_s, tableEnd_s]: the grid point at or before the start
    // to the one at or after the end.
    const std::size_t first = static_cast<std::size_t>(std::floor((tableStart_s - t0) / p.dt_s));
    const std::size_t last = static_cast<std::size_t>(std::ceil((tableEnd_s - t0) / p.dt_s));
    const double tableT0 = t0 + static_cast<double>(first) * p.dt_s;
    SurfaceTemperatureTable table(classes.size(), last - first + 1, tableT0, p.dt_s);
    HeatBalanceReport rep;
    std::uint64_t key = 0;
    if (!cacheDir.empty()) {
        if (!std::filesystem::is_directory(cacheDir))
            throw SetupError(cacheDir.string() + ": thermal cache folder does not exist");
        key = heatBalanceKey(classes, weather, site, p, tableStart_s, tableEnd_s);
        char hex[17];
        std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(key));
        rep.cacheFile = cacheDir / ("thermal-" + std::string(hex) + ".bin");
        rep.fromCache = readCache(rep.cacheFile, key, table);
    }
    if (!rep.fromCache) {
        const std::size_t day = static_cast<std::size_t>(std::llround(86400.0 / p.dt_s));
        ForcingParams fp = p.forcing;
        fp.siteAltitude_m = site.height_m;
        const std::vector<ForcingSample> f =
            forcingSeries(weather, site, fp, t0, p.dt_s, std::max(last, day) + 1);
        double meanAir = 0.0;
        for (std::size_t i = 0; i < day; ++i)
            meanAir += f[i].weather.air_K / static_cast<double>(day);
        rep.stateBytes = f.capacity() * sizeof(ForcingSample) + table.bytes();
        for (std::size_t k = 0; k < classes.size(); ++k) {
            const SurfaceClass& c = classes[k];
            SurfaceSolver s(c.material, c.exposure, p.grid, meanAir);
            rep.spinupDays.push_back(spinUp(s, c, f, day, t0, p));
            rep.stateBytes += s.stateBytes();
            const double spunSurface_K = s.surface_K();
            for (std::size_t i = 1; i <= last; ++i) {
                s.step(f[i], sunlitAt(c, t0 + static_cast<double>(i) * p.dt_s), p.dt_s);
                if (i >= first) table.sample(k, i - first) = static_cast<float>(s.surface_K());
            }
            if (first == 0) table.sample(k, 0) = static_cast<float>(spunSurface_K);
            rep.dew_kg_m2.push_back(s.dew_kg_m2());
            rep.unconvergedSteps += s.unconvergedSteps();
        }
        if (!cacheDir.empty()) writeCache(rep.cacheFile, key, table);
    }
    if (report) *report = rep;
    return table;
}

double surfaceTemperature_K(const SurfaceClass& surfaceClass, const WeatherSeries& weather,
                            const astro::Site& site, const HeatBalanceParams& p, double t_s,
                            const std::filesystem::path& cacheDir) {
    const SurfaceTemperatureTable t =
        solveHeatBalance({surfaceClass}, weather, site, p, t_s, t_s, cacheDir);
    return t.at(0, t_s);
}

}  // namespace nvs::thermal
