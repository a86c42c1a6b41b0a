#pragma once
// A frame rate as an exact rational (DESIGN §5): dt = den/num seconds, so that 59.94 Hz
// (60000/1001) does not drift. The clocks that tick at it are the runtime's (rt/clock); the
// value lives here because a file format carries it too (the y4m header's F num:den).

#include <cmath>
#include <cstdint>
#include <string>

#include "sim/core/error.h"

namespace nvs::msg {

// A frame rate as an exact fraction num/den [Hz].
struct FrameRate {
    std::int64_t num = 60;
    std::int64_t den = 1;

    double hz() const { return static_cast<double>(num) / static_cast<double>(den); }
    double period_s() const { return static_cast<double>(den) / static_cast<double>(num); }
    // 59.94 → 60000/1001, 29.97 → 30000/1001, 23.976 → 24000/1001, integers → n/1, else the
    // value in millihertz. Throws SetupError for non-positive or absurd rates.
    static FrameRate fromHz(double hz) {
        if (!(hz > 0.0) || hz > 10000.0) {
            throw SetupError("frame rate " + std::to_string(hz) + " Hz: must be in (0, 10000]");
        }
        // The NTSC family is (n·1000/1001) Hz; accept its usual two-decimal spellings.
        for (const std::int64_t n : {24, 30, 48, 60, 120}) {
            const double ntsc = static_cast<double>(n) * 1000.0 / 1001.0;
            if (std::fabs(hz - ntsc) < 0.006) return {n * 1000, 1001};
        }
        if (std::fabs(hz - std::round(hz)) < 1e-9)
            return {static_cast<std::int64_t>(std::llround(hz)), 1};
        return {static_cast<std::int64_t>(std::llround(hz * 1000.0)), 1000};
    }
};

}  // namespace nvs::msg
