#include "rt/stats/stats.h"

#include <cmath>
#include <cstdio>

namespace nvs::rt {

void DurationHistogram::add(double d_s) noexcept {
    if (!(d_s >= 0.0)) d_s = 0.0;  // clock steps and NaN count as zero
    ++count_;
    sum_s_ += d_s;
    if (d_s > max_s_) max_s_ = d_s;
    if (d_s < min_s_) min_s_ = d_s;
    const double b = std::floor(d_s / kBin_s);
    if (b >= static_cast<double>(kBins)) {
        ++overflow_;
    } else {
        ++bins_[static_cast<std::size_t>(b)];
    }
}

double DurationHistogram::quantile_s(double q) const noexcept {
    if (count_ == 0) return 0.0;
    // Nearest-rank: the smallest value with at least ceil(q·n) samples at or below it.
    std::int64_t rank = static_cast<std::int64_t>(std::ceil(q * static_cast<double>(count_)));
    if (rank < 1) rank = 1;
    std::int64_t seen = 0;
    for (int i = 0; i < kBins; ++i) {
        seen += bins_[static_cast<std::size_t>(i)];
        if (seen >= rank) {
            const double upper = static_cast<double>(i + 1) * kBin_s;
            return upper < max_s_ ? upper : max_s_;
        }
    }
    return max_s_;
}

std::string DurationHistogram::json() const {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "{\"n\":%lld,\"p50_s\":%.9g,\"p99_s\":%.9g,\"max_s\":%.9g,\"mean_s\":%.9g}",
                  static_cast<long long>(count_), quantile_s(0.5), quantile_s(0.99), max_s_,
                  mean_s());
    return buf;
}

}  // namespace nvs::rt
