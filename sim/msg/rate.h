#pragma once
// A frame rate as an exact rational (docs/design.md §5): dt = den/num seconds, so that 59.94 Hz
// (60000/1001) does not drift. The clocks that tick at it are the runtime's (rt/clock); the
// value lives here because a file format carries it too (the y4m header's F num:den).

#include <cmath>
#include <cstdint>
#include <string>

#include "sim/core/error.h"

namespace nvs::msg {

// A frame rate as an exact fraction num/den [Hz].
struct FrameRate {
    // The rates nvstim runs at: at least one frame per 1000 s, at most 10 kHz. Below the
    // minimum the millionths of a hertz that hold a sub-hertz rate round to nothing (a rate
    // with numerator 0 divided by zero in the clocks).
    static constexpr double kMin_hz = 0.001;
    static constexpr double kMax_hz = 10000.0;
    // Bounds of num and den: k·den·10⁹ stays within the clocks' 128-bit products for any
    // 64-bit tick k.
    static constexpr std::int64_t kMaxTerm = 1'000'000'000;

    std::int64_t num = 60;
    std::int64_t den = 1;

    double hz() const { return static_cast<double>(num) / static_cast<double>(den); }
    double period_s() const { return static_cast<double>(den) / static_cast<double>(num); }
    // num and den positive and bounded, the rate within [kMin_hz, kMax_hz].
    bool valid() const {
        return num >= 1 && den >= 1 && num <= kMaxTerm && den <= kMaxTerm && hz() >= kMin_hz &&
               hz() <= kMax_hz;
    }
    // 59.94 → 60000/1001, 29.97 → 30000/1001, 23.976 → 24000/1001, integers → n/1, other
    // rates of 1 Hz and more in millihertz, below 1 Hz in microhertz. Throws SetupError for
    // a rate outside [kMin_hz, kMax_hz] (NaN included).
    static FrameRate fromHz(double hz) {
        if (!(hz >= kMin_hz && hz <= kMax_hz)) {
            throw SetupError("frame rate " + std::to_string(hz) + " Hz: must be in [0.001, 10000]");
        }
        // The NTSC family is (n·1000/1001) Hz; accept its usual two-decimal spellings.
        for (const std::int64_t n : {24, 30, 48, 60, 120}) {
            const double ntsc = static_cast<double>(n) * 1000.0 / 1001.0;
            if (std::fabs(hz - ntsc) < 0.006) return {n * 1000, 1001};
        }
        if (std::fabs(hz - std::round(hz)) < 1e-9)
            return {static_cast<std::int64_t>(std::llround(hz)), 1};
        if (hz < 1.0) return {static_cast<std::int64_t>(std::llround(hz * 1e6)), 1'000'000};
        return {static_cast<std::int64_t>(std::llround(hz * 1000.0)), 1000};
    }
    // This rate, or SetupError naming `what` when it is not valid() (the clocks' check).
    const FrameRate& checked(const char* what) const {
        if (!valid()) {
            throw SetupError(std::string(what) + ": frame rate " + std::to_string(num) + "/" +
                             std::to_string(den) + " Hz is outside [0.001, 10000] Hz");
        }
        return *this;
    }
};

}  // namespace nvs::msg
