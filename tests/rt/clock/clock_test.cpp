// Frame rates at their limits (docs/reliability-inputs.md): a rate below 0.001 Hz rounded to
// a numerator of 0 and the wall clock divided by it (SIGFPE); such rates are refused where they
// are read and where a clock is made, and the rates that remain keep exact deadlines.
#include "rt/clock/clock.h"

#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "sim/core/error.h"

namespace nvs::rt {
namespace {

TEST(FrameRateBounds, RatesOutsideTheRangeAreRefused) {
    for (const double hz :
         {0.0004, 0.0, -1.0, 10000.5, std::nan(""), std::numeric_limits<double>::infinity()}) {
        EXPECT_THROW(FrameRate::fromHz(hz), SetupError) << hz;
    }
    // The smallest rate: one frame per 1000 s, exactly.
    const FrameRate slow = FrameRate::fromHz(0.001);
    EXPECT_TRUE(slow.valid());
    EXPECT_DOUBLE_EQ(slow.period_s(), 1000.0);
    // Sub-hertz rates in microhertz: 0.0014 Hz is not rounded to 0.001 Hz.
    EXPECT_NEAR(FrameRate::fromHz(0.0014).hz(), 0.0014, 1e-12);
    EXPECT_EQ(FrameRate::fromHz(0.5).num, 500000);
    // Rates of 1 Hz and more keep their millihertz form (the y4m header's F num:den).
    EXPECT_EQ(FrameRate::fromHz(12.5).num, 12500);
    EXPECT_EQ(FrameRate::fromHz(12.5).den, 1000);
}

TEST(FrameRateBounds, ClocksRefuseARateTheyCannotComputeWith) {
    // FrameRate{0, 1000} is what fromHz(0.0004) returned: WallClock::deadline_ns divided by 0.
    EXPECT_THROW(WallClock(FrameRate{0, 1000}), SetupError);
    EXPECT_THROW(SimClock(FrameRate{0, 1000}), SetupError);
    EXPECT_THROW(WallClock(FrameRate{-60, 1}), SetupError);
    EXPECT_THROW(WallClock(FrameRate{1, 0}), SetupError);
    EXPECT_THROW(WallClock(FrameRate{std::numeric_limits<std::int64_t>::max(), 1}), SetupError);
}

TEST(FrameRateBounds, SlowestRateKeepsExactDeadlines) {
    WallClock c(FrameRate::fromHz(0.001));
    c.start(0);
    EXPECT_EQ(c.deadline_ns(1), 1'000'000'000'000);
    // Far ticks: k·den·10⁹ exceeds 64 bits and is computed in 128.
    EXPECT_EQ(c.deadline_ns(9'000'000), 9'000'000'000'000'000'000);
    EXPECT_EQ(c.tickAt(2'500'000'000'000), 2);
}

}  // namespace
}  // namespace nvs::rt
