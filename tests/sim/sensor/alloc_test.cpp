// The frame loop allocates nothing: global operator new is replaced in this test binary
// (rt/bench/count_new.cpp) and counts every allocation while fields are processed with every stage
// on.

#include <gtest/gtest.h>

#include <cstdint>

#include "rt/bench/alloc_count.h"
#include "sim/sensor/chain.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace nvs::sensor {
namespace {

TEST(Allocation, NoneWhileProcessingFields) {
    if (!rt::bench::allocationCounting())
        GTEST_SKIP() << "operator new is not replaced in this build (AddressSanitizer)";
    for (const char* mode : {"off", "agc", "abc", "bsp", "autogate"}) {
        const CameraParams cam = test::preset("pulnix-ag5745ef3", {{"width", "160"},
                                                                   {"height", "120"},
                                                                   {"agc", mode},
                                                                   {"ccd.prnu_rel", "0.05"},
                                                                   {"ccd.smear_rel", "0.01"},
                                                                   {"ccd.dark_e_s", "100"}});
        IiccdChain chain(cam, 9, test::configDir(), test::gammaTables());
        ImageF in = test::uniform(160, 120, 3e11f);
        for (int y = 50; y < 60; ++y)
            for (int x = 70; x < 80; ++x)
                in(x, y) = 1e15f;   // saturates and blooms
        chain.process(in.cview());  // warm-up (nothing lazily allocated either)
        const std::uint64_t before = rt::bench::allocationCount();
        for (int k = 0; k < 6; ++k)
            chain.process(in.cview());
        EXPECT_EQ(rt::bench::allocationCount() - before, 0u) << mode;
    }
}

}  // namespace
}  // namespace nvs::sensor
