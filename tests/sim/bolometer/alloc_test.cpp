// The frame loop allocates nothing: global operator new is replaced in this test binary
// (rt/bench/count_new.cpp) and counts every allocation while frames are processed, FFCs and
// both AGC modes included.

#include <gtest/gtest.h>

#include <cstdint>

#include "rt/bench/alloc_count.h"
#include "tests/sim/bolometer/bolometer_test_util.h"

namespace nvs::bolometer {
namespace {

TEST(BolometerAllocation, NoneWhileProcessingFrames) {
    if (!rt::bench::allocationCounting())
        GTEST_SKIP() << "operator new is not replaced in this build (AddressSanitizer)";
    for (const char* mode : {"linear", "plateau"}) {
        const ThermalCameraParams cam = test::thermalPreset(
            "boson-320",
            {{"width", "80"}, {"height", "64"}, {"agc.mode", mode}, {"shutter.interval_s", "0.5"}});
        BolometerChain chain(cam, 9);
        const ImageF in = test::blackbody(cam, 300.0);
        chain.process(in.cview());  // warm-up
        const std::uint64_t before = rt::bench::allocationCount();
        for (int k = 0; k < 60; ++k)  // two FFCs
            chain.process(in.cview());
        EXPECT_EQ(rt::bench::allocationCount() - before, 0u) << mode;
        EXPECT_GE(chain.lastInfo().ffc_count, 2u);
    }
}

// The full-size shipped preset with the optics planned from the shipped wisdom (its SSE2 plans,
// not the small frame's scalar estimate).
TEST(BolometerAllocation, NoneWithTheShippedWisdomPlans) {
    if (!rt::bench::allocationCounting())
        GTEST_SKIP() << "operator new is not replaced in this build (AddressSanitizer)";
    const ThermalCameraParams cam = test::thermalPreset("boson-320");
    BolometerChain chain(cam, 9, test::configDir());
    ASSERT_TRUE(chain.optics().plannedFromWisdom());
    const ImageF in = test::blackbody(cam, 300.0);
    chain.process(in.cview());  // warm-up
    const std::uint64_t before = rt::bench::allocationCount();
    for (int k = 0; k < 40; ++k)  // past the start-up FFC
        chain.process(in.cview());
    EXPECT_EQ(rt::bench::allocationCount() - before, 0u);
    EXPECT_FALSE(chain.lastInfo().frozen);
}

}  // namespace
}  // namespace nvs::bolometer
