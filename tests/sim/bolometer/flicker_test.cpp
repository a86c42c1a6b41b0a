// The 1/f noise (Voss–McCartney, sim/bolometer/stages/noise.h) against two laws:
// - its stationary variance is the preset's (flicker_rel·σ)², added to the white σ² (the
//   generators are independent of the white noise);
// - flicker (1/f) noise has an Allan variance that does not depend on the averaging time τ,
//   where white noise's falls as 1/τ (Allan, "Statistics of atomic frequency standards",
//   Proc. IEEE 54(2), 1966; Barnes et al., "Characterization of frequency stability", IEEE
//   Trans. Instrum. Meas. IM-20(2), 1971, Table I: σ²(τ) = 2 ln2·h₋₁ for S(f) = h₋₁/f).
// The 1/f part is made 3× the white σ here so that it dominates from τ = 4 frames on; the white
// part of the Allan variance, σ_w²/n for n-frame averages, is taken off with its analytic value.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "tests/sim/bolometer/bolometer_test_util.h"

namespace nvs::bolometer {
namespace {

TEST(Flicker, StationaryVarianceAndFlatAllanVariance) {
    const ThermalCameraParams cam =
        test::thermalPreset("boson-320", {{"width", "32"},
                                          {"height", "32"},
                                          {"noise.flicker_rel", "3.0"},
                                          {"noise.row_rel", "0"},
                                          {"noise.column_rel", "0"},
                                          {"focal_plane.self_heating_K", "0"}});
    BolometerChain chain(cam, 21);
    const ImageF scene = test::blackbody(cam, 300.0);
    test::pastStartupFfc(chain, scene, 0);
    constexpr int kFrames = 4096, kPx = 32 * 32;
    std::vector<double> series(static_cast<std::size_t>(kFrames) * kPx);
    for (int k = 0; k < kFrames; ++k) {
        ASSERT_FALSE(chain.process(scene.cview()).frozen);
        for (int i = 0; i < kPx; ++i)
            series[static_cast<std::size_t>(i) * kFrames + k] = chain.raw()(i % 32, i / 32);
    }
    // White σ in counts: NETD of the camera (0.040 K, netd_test.cpp) × 50 counts/K at
    // 300 K, plus the ADC's quantisation (1/12 count²).
    const double sw = 0.040 * 50.0;
    const double white2 = sw * sw + 1.0 / 12.0;
    double var = 0.0;
    for (int i = 0; i < kPx; ++i) {
        const double* s = &series[static_cast<std::size_t>(i) * kFrames];
        double m = 0.0, m2 = 0.0;
        for (int k = 0; k < kFrames; ++k) {
            m += s[k];
            m2 += s[k] * s[k];
        }
        var += (m2 - m * m / kFrames) / (kFrames - 1) / kPx;
    }
    EXPECT_NEAR(var, white2 + 9.0 * sw * sw, 0.10 * (white2 + 9.0 * sw * sw));
    // Allan variance of n-frame averages, the white part σ_w²/n taken off.
    std::vector<double> flick;
    for (const int n : {4, 8, 16, 32}) {
        double acc = 0.0;
        int terms = 0;
        for (int i = 0; i < kPx; ++i) {
            const double* s = &series[static_cast<std::size_t>(i) * kFrames];
            double prev = 0.0;
            for (int b = 0; b < kFrames / n; ++b) {
                double y = 0.0;
                for (int k = 0; k < n; ++k)
                    y += s[b * n + k];
                y /= n;
                if (b > 0) {
                    acc += 0.5 * (y - prev) * (y - prev);
                    ++terms;
                }
                prev = y;
            }
        }
        flick.push_back(acc / terms - white2 / n);
    }
    std::printf(
        "variance %.2f counts² (expected %.2f); 1/f Allan variance n=4..32: %.3f %.3f %.3f "
        "%.3f\n",
        var, white2 + 9.0 * sw * sw, flick[0], flick[1], flick[2], flick[3]);
    double mean = 0.0;
    for (double f : flick)
        mean += f / static_cast<double>(flick.size());
    for (std::size_t i = 0; i < flick.size(); ++i)
        EXPECT_NEAR(flick[i], mean, 0.25 * mean) << "n = " << (4 << i);
    // White noise alone would have fallen 8× from n = 4 to 32.
    EXPECT_GT(flick.back(), 0.5 * flick.front());
}

}  // namespace
}  // namespace nvs::bolometer
