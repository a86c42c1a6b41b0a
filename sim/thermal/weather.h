#pragma once
// The weather history that drives the heat balance (docs/thermal.md §2): a CSV time series
//
//   # source: <the record or climatology the values come from>
//   utc,air_temperature_C,dew_point_C,wind_speed_m_s,cloud_fraction,cloud_base_m
//   1998-08-31T00:00Z,22.0,12.0,2.5,0.2,2500
//
// UTC instants in ISO 8601, strictly increasing, with no gap over kMaxWeatherGap_s (3 h:
// the heat balance's surface responds within an hour, so a longer gap would be invented
// weather); wind at 10 m; cloud fraction in [0, 1] (oktas/8); cloud base above the ground.
// Values are interpolated linearly in time. Times are seconds since 1970-01-01T00:00Z (UTC,
// leap seconds not counted, as POSIX time).

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "sim/astro/time.h"
#include "sim/core/error.h"

namespace nvs::thermal {

inline constexpr double kMaxWeatherGap_s = 3.0 * 3600.0;
inline constexpr double kCelsiusZero_K = 273.15;

struct WeatherSample {
    double air_K = 288.15;
    double dewPoint_K = 280.0;
    double wind_m_s = 2.0;
    double cloudFraction = 0.0;
    double cloudBase_m = 2000.0;
};

// POSIX seconds of a UTC calendar instant (days from the civil calendar, Hinnant's algorithm).
double utcSeconds(const astro::CalendarInstant& utc) noexcept;
// The same from ISO 8601 text; throws SetupError "<what>: ..." when malformed.
double utcSeconds(std::string_view iso, const std::string& what);

class WeatherSeries {
  public:
    static WeatherSeries load(const std::filesystem::path& path);
    static WeatherSeries parse(std::string_view text, const std::string& name);
    // A series built in code (tests): times strictly increasing, gaps ≤ kMaxWeatherGap_s.
    static WeatherSeries fromSamples(std::vector<double> t_s, std::vector<WeatherSample> samples,
                                     std::string source);

    // Linear interpolation; clamped to the first/last sample outside the series.
    // Per step: no allocation, no throw.
    WeatherSample at(double t_s) const noexcept;
    double start_s() const { return t_.front(); }
    double end_s() const { return t_.back(); }
    const std::string& source() const { return source_; }
    const std::string& file() const { return file_; }
    std::size_t size() const { return t_.size(); }
    const std::vector<double>& times_s() const { return t_; }
    const std::vector<WeatherSample>& samples() const { return w_; }

  private:
    std::vector<double> t_;
    std::vector<WeatherSample> w_;
    std::string source_;
    std::string file_;
};

}  // namespace nvs::thermal
