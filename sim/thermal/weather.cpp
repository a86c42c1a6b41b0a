#include "sim/thermal/weather.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "sim/core/csv.h"
#include "sim/core/input_file.h"

namespace nvs::thermal {

double utcSeconds(const astro::CalendarInstant& utc) noexcept {
    // Days since 1970-01-01 of a proleptic Gregorian date (H. Hinnant, "chrono-compatible
    // low-level date algorithms", days_from_civil).
    const int y = utc.year - (utc.month <= 2 ? 1 : 0);
    const int era = (y >= 0 ? y : y - 399) / 400;
    const int yoe = y - era * 400;
    const int mp = (utc.month + 9) % 12;
    const int doy = (153 * mp + 2) / 5 + utc.day - 1;
    const int doe = yoe * 365 + yoe / 4 - yoe / 100 + doy;
    const double days = era * 146097.0 + doe - 719468.0;
    return days * 86400.0 + utc.hour * 3600.0 + utc.minute * 60.0 + utc.second;
}

double utcSeconds(std::string_view iso, const std::string& what) {
    return utcSeconds(astro::parseIsoUtc(iso, what));
}

namespace {

// Checks one sample's ranges; `loc` names the row.
void checkSample(const WeatherSample& w, const FileLoc& loc) {
    if (!(w.air_K > 200.0 && w.air_K < 340.0))
        throw SetupError(loc, "air temperature outside (-73, 67) °C");
    if (!(w.dewPoint_K > 180.0 && w.dewPoint_K <= w.air_K + 0.5))
        throw SetupError(loc, "dew point above the air temperature or below -93 °C");
    if (!(w.wind_m_s >= 0.0 && w.wind_m_s < 60.0))
        throw SetupError(loc, "wind speed outside [0, 60) m/s");
    if (!(w.cloudFraction >= 0.0 && w.cloudFraction <= 1.0))
        throw SetupError(loc, "cloud fraction outside [0, 1]");
    if (!(w.cloudBase_m > 0.0 && w.cloudBase_m < 20000.0))
        throw SetupError(loc, "cloud base outside (0, 20000) m");
}

// Checks the order and gaps of the times; `loc(i)` names row i.
template <class Loc>
void checkTimes(const std::vector<double>& t, Loc loc) {
    for (std::size_t i = 1; i < t.size(); ++i) {
        if (!(t[i] > t[i - 1])) throw SetupError(loc(i), "time not after the previous row's");
        if (t[i] - t[i - 1] > kMaxWeatherGap_s) {
            char gap[32];
            std::snprintf(gap, sizeof gap, "%.2f", (t[i] - t[i - 1]) / 3600.0);
            throw SetupError(
                loc(i), std::string("gap of ") + gap + " h since the previous row (at most 3 h)");
        }
    }
}

WeatherSeries fromTable(const CsvTable& c) {
    if (c.commentValue("source").empty())
        throw SetupError(FileLoc{c.file(), 1, 0}, "weather file without a '# source:' line");
    if (c.rowCount() < 2) throw SetupError(c.headerLoc(), "weather file needs two rows or more");
    const std::size_t cu = c.column("utc"), ca = c.column("air_temperature_C"),
                      cd = c.column("dew_point_C"), cw = c.column("wind_speed_m_s"),
                      cf = c.column("cloud_fraction"), cb = c.column("cloud_base_m");
    std::vector<double> t;
    std::vector<WeatherSample> w;
    for (std::size_t i = 0; i < c.rowCount(); ++i) {
        const FileLoc loc = c.rowLoc(i);
        t.push_back(utcSeconds(c.row(i)[cu], loc.str() + ": utc"));
        WeatherSample s;
        s.air_K = c.number(i, ca) + kCelsiusZero_K;
        s.dewPoint_K = c.number(i, cd) + kCelsiusZero_K;
        s.wind_m_s = c.number(i, cw);
        s.cloudFraction = c.number(i, cf);
        s.cloudBase_m = c.number(i, cb);
        checkSample(s, loc);
        w.push_back(s);
    }
    checkTimes(t, [&](std::size_t i) { return c.rowLoc(i); });
    WeatherSeries s =
        WeatherSeries::fromSamples(std::move(t), std::move(w), c.commentValue("source"));
    return s;
}

}  // namespace

WeatherSeries WeatherSeries::fromSamples(std::vector<double> t_s,
                                         std::vector<WeatherSample> samples, std::string source) {
    if (t_s.size() < 2 || t_s.size() != samples.size())
        throw SetupError("weather: two samples or more, one time each");
    checkTimes(t_s, [](std::size_t i) {
        return FileLoc{"weather sample " + std::to_string(i), 0, 0};
    });
    WeatherSeries s;
    s.t_ = std::move(t_s);
    s.w_ = std::move(samples);
    s.source_ = std::move(source);
    return s;
}

WeatherSeries WeatherSeries::load(const std::filesystem::path& path) {
    if (!pathExists(path)) throw SetupError(path.string() + ": weather file not found");
    WeatherSeries s = fromTable(CsvTable::load(path));
    s.file_ = path.string();
    return s;
}

WeatherSeries WeatherSeries::parse(std::string_view text, const std::string& name) {
    WeatherSeries s = fromTable(CsvTable::parse(text, name));
    s.file_ = name;
    return s;
}

WeatherSample WeatherSeries::at(double t_s) const noexcept {
    if (t_s <= t_.front()) return w_.front();
    if (t_s >= t_.back()) return w_.back();
    const auto it = std::upper_bound(t_.begin(), t_.end(), t_s);
    const std::size_t i = static_cast<std::size_t>(it - t_.begin());
    const double f = (t_s - t_[i - 1]) / (t_[i] - t_[i - 1]);
    const WeatherSample& a = w_[i - 1];
    const WeatherSample& b = w_[i];
    auto mix = [f](double x, double y) { return x + f * (y - x); };
    return {mix(a.air_K, b.air_K), mix(a.dewPoint_K, b.dewPoint_K), mix(a.wind_m_s, b.wind_m_s),
            mix(a.cloudFraction, b.cloudFraction), mix(a.cloudBase_m, b.cloudBase_m)};
}

}  // namespace nvs::thermal
