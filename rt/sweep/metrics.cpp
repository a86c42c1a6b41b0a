#include "rt/sweep/metrics.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <limits>
#include <sstream>
#include <vector>

#include "sim/core/error.h"
#include "sim/core/fnv.h"
#include "sim/io/pnm.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();  // absent: null in JSON

const std::vector<std::string>& runMetricNames() {
    static const std::vector<std::string> names = {
        "frames",           "mean_counts", "std_counts",     "p99_counts",  "adc_top",
        "adc_top_fraction", "frames_fnv",  "frames_emitted", "sink_errors", "frame_time_mean_s"};
    return names;
}

bool timingColumn(const std::string& name) {
    return name == "wall_s" || name == "frame_time_mean_s" || name == "host";
}

Json measureRun(const fs::path& framesDir, const fs::path& statsFile) {
    std::vector<fs::path> files;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(framesDir, ec))
        if (e.path().extension() == ".pgm") files.push_back(e.path());
    if (ec) throw SetupError(framesDir.string() + ": cannot list the frames");
    std::sort(files.begin(), files.end());

    // One histogram of every count: the mean, the spread and the percentile exactly.
    std::vector<std::uint64_t> histogram(65536, 0);
    std::uint64_t n = 0;
    int top = -1;
    Fnv1a fnv;
    for (const fs::path& f : files) {
        std::ifstream in(f, std::ios::binary);
        std::ostringstream bytes;
        bytes << in.rdbuf();
        int maxValue = 0;
        const ImageU16 img = io::parsePgm(bytes.str(), f.string(), {}, &maxValue);
        if (top >= 0 && maxValue != top) {
            throw SetupError(f.string() + ": maximum value " + std::to_string(maxValue) +
                             " differs from the first frame's " + std::to_string(top));
        }
        top = maxValue;
        for (int y = 0; y < img.height(); ++y) {
            const std::uint16_t* row = img.row(y);
            for (int x = 0; x < img.width(); ++x) {
                ++histogram[row[x]];
                const unsigned char le[2] = {static_cast<unsigned char>(row[x] & 0xff),
                                             static_cast<unsigned char>(row[x] >> 8)};
                fnv.bytes(le, 2);
            }
        }
        n += static_cast<std::uint64_t>(img.width()) * static_cast<std::uint64_t>(img.height());
    }
    Json m = Json::object();
    m.set("frames", Json::number(static_cast<double>(files.size())));
    if (n == 0) throw SetupError(framesDir.string() + ": no frames");
    // Sums in long double over the histogram: exact for any sweep's pixel count.
    long double sum = 0.0L, sum2 = 0.0L;
    for (std::size_t v = 0; v < histogram.size(); ++v) {
        sum += static_cast<long double>(histogram[v]) * static_cast<long double>(v);
        sum2 += static_cast<long double>(histogram[v]) * static_cast<long double>(v) *
                static_cast<long double>(v);
    }
    const long double mean = sum / static_cast<long double>(n);
    const long double var = std::max(0.0L, sum2 / static_cast<long double>(n) - mean * mean);
    // p99: the smallest v with count(≤ v) ≥ 0.99 n, i.e. count(≤ v) · 100 ≥ 99 n in integers.
    std::uint64_t below = 0;
    std::size_t p99 = 0;
    for (; p99 < histogram.size(); ++p99) {
        below += histogram[p99];
        if (below * 100 >= n * 99) break;
    }
    m.set("mean_counts", Json::number(static_cast<double>(mean)));
    m.set("std_counts", Json::number(static_cast<double>(std::sqrt(var))));
    m.set("p99_counts", Json::number(static_cast<double>(p99)));
    m.set("adc_top", Json::number(top));
    m.set("adc_top_fraction",
          Json::number(static_cast<double>(histogram[static_cast<std::size_t>(top)]) /
                       static_cast<double>(n)));
    char digest[20];
    std::snprintf(digest, sizeof digest, "%016llx", static_cast<unsigned long long>(fnv.h));
    m.set("frames_fnv", Json::string(digest));

    std::ifstream in(statsFile, std::ios::binary);
    if (!in) throw SetupError(statsFile.string() + ": no statistics");
    std::ostringstream text;
    text << in.rdbuf();
    const Json stats = parseJson(text.str(), statsFile.string());
    m.set("frames_emitted", Json::number(stats.numberOr("frames_emitted", kNaN)));
    m.set("sink_errors", Json::number(stats.numberOr("sink_errors", kNaN)));
    const Json* ft = stats.find("frame_time");
    m.set("frame_time_mean_s", Json::number(ft != nullptr ? ft->numberOr("mean_s", kNaN) : kNaN));
    return m;
}

}  // namespace nvs::rt::sweep
