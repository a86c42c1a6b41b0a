// The optics' FFT plans from the shipped wisdom (config/fftw/, sim/core/fft_plans.h,
// docs/portability.md): the shipped thermal presets' padded sizes are in it (without them the
// MTF falls back to the scalar estimated plans, 3-4 times slower), and a plan from wisdom
// computes the same filtered image as the estimated one to single-precision rounding (a
// different sequence of operations, the same transform).

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>

#include "sim/core/planck.h"
#include "tests/sim/bolometer/bolometer_test_util.h"

namespace nvs::bolometer {
namespace {

TEST(OpticsWisdom, ShippedPresetsArePlannedFromTheShippedWisdom) {
    for (const char* preset : {"boson-640", "boson-320"}) {
        const ThermalCameraParams cam = test::thermalPreset(preset);
        const OpticsStage shipped(cam, test::configDir());
        EXPECT_TRUE(shipped.plannedFromWisdom()) << preset;
        const OpticsStage none(cam, {});  // no config folder: the scalar estimate
        EXPECT_FALSE(none.plannedFromWisdom()) << preset;
        EXPECT_EQ(shipped.paddedWidth(), none.paddedWidth());
    }
}

TEST(OpticsWisdom, AnotherSizeFallsBackToTheEstimate) {
    const ThermalCameraParams cam =
        test::thermalPreset("boson-640", {{"width", "200"}, {"height", "150"}});
    const OpticsStage optics(cam, test::configDir());
    EXPECT_FALSE(optics.plannedFromWisdom());
}

TEST(OpticsWisdom, WisdomPlanFiltersAsTheEstimatedPlan) {
    const ThermalCameraParams cam = test::thermalPreset("boson-640");
    OpticsStage shipped(cam, test::configDir()), estimated(cam, {});
    ImageF in(cam.width, cam.height), a(cam.width, cam.height), b(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
            const double T_K =
                (x > 200 && x < 300 && y > 100 && y < 200) ? 340.0 : 280.0 + 40.0 * x / cam.width;
            in(x, y) = static_cast<float>(planckBandRadiance_W_m2_sr(7.5, 13.5, T_K));
        }
    shipped.apply(in.cview(), a.view());
    estimated.apply(in.cview(), b.view());
    double maxV = 0.0, maxDiff = 0.0;
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
            maxV = std::max(maxV, static_cast<double>(b(x, y)));
            maxDiff = std::max(
                maxDiff, std::abs(static_cast<double>(a(x, y)) - static_cast<double>(b(x, y))));
        }
    ASSERT_GT(maxV, 0.0);
    // A 672 × 576 single-precision FFT round trip: errors of order ε·log2(N) ≈ 2e-6 of the
    // largest value.
    EXPECT_LT(maxDiff / maxV, 1e-5);
}

}  // namespace
}  // namespace nvs::bolometer
