// Shutter flat-field correction: the residual fixed pattern after an FFC is below one NETD,
// it grows with the focal plane's drift at the rate the preset's per-pixel drift coefficients
// imply, a temperature change of delta_K starts the next FFC, and the frames the shutter is
// closed are frozen and flagged.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <vector>

#include "sim/core/planck.h"
#include "tests/sim/bolometer/bolometer_test_util.h"

namespace nvs::bolometer {
namespace {

// Residual fixed pattern [K]: the spatial σ of the mean of `frames` frames, divided by the
// preset's 50 counts/K at 300 K (the scene is a 300 K blackbody).
double residualFpn_K(BolometerChain& chain, const ImageF& scene, int frames) {
    test::PixelStats s(static_cast<std::size_t>(scene.width() * scene.height()));
    for (int k = 0; k < frames; ++k) {
        EXPECT_FALSE(chain.process(scene.cview()).frozen);
        s.add(chain.raw());
    }
    return s.spatialStdOfMeans() / 50.0;
}

// Focal plane drifting at 0.02 K/s (set rate), no self-heating; 1/f off (its slowest
// generators would look like fixed pattern over a 1 s average).
ThermalCameraParams driftingCamera() {
    return test::thermalPreset("boson-640", {{"width", "128"},
                                             {"height", "96"},
                                             {"focal_plane.self_heating_K", "0"},
                                             {"focal_plane.drift_K_s", "0.02"},
                                             {"noise.flicker_rel", "0"}});
}

TEST(Ffc, ResidualBelowOneNetdAndGrowsWithDriftAtTheSetRate) {
    const ThermalCameraParams cam = driftingCamera();
    BolometerChain chain(cam, 3);
    const ImageF scene = test::blackbody(cam, 300.0);
    // Before any FFC the raw offsets (σ = 2 K) show: the first frame is frozen (start-up FFC).
    test::pastStartupFfc(chain, scene, 0);
    const double t0 = chain.lastInfo().t_s;
    const double netd_K = 0.040;  // the camera's NETD (netd_test.cpp)
    const double r0 = residualFpn_K(chain, scene, 60);
    EXPECT_LT(r0, netd_K);
    // What remains is the temporal noise of the two averages: the shutter's 24 − 4 = 20 frames
    // (preset: closed_frames − settle_frames) and the 60 measured, σ = NETD·√(1/20 + 1/60).
    // (The gain pattern, 0.2 %, times the scene's signal less the shutter's adds little here:
    // the 300 K scene through the 0.9 lens gives nearly the 293 K shutter's signal.)
    const double expected0 = netd_K * std::sqrt(1.0 / 20.0 + 1.0 / 60.0);
    EXPECT_NEAR(r0, expected0, 0.15 * expected0);
    // Growth: σ(t)² = σ₀² + (σ_c·rate·t)², σ_c = 0.3 K/K (preset), rate = 0.02 K/s, so the
    // pattern's σ grows at σ_c·rate = 0.006 K/s once it dominates. Measured 15–60 s after the
    // FFC (ΔT_fpa 0.3–1.2 K, below delta_K = 1.5 K).
    std::vector<double> t, g;
    for (int step = 1; step <= 4; ++step) {
        while (chain.lastInfo().t_s - t0 < 15.0 * step)
            chain.process(scene.cview());
        const double tm = chain.lastInfo().t_s + 0.5 * 60.0 / cam.frame_rate_Hz;
        const double r = residualFpn_K(chain, scene, 60);
        t.push_back(tm - t0);
        g.push_back(std::sqrt(std::max(r * r - r0 * r0, 0.0)));
    }
    // Least-squares slope through the origin.
    double num = 0.0, den = 0.0;
    for (std::size_t i = 0; i < t.size(); ++i) {
        num += t[i] * g[i];
        den += t[i] * t[i];
    }
    std::printf("residual after FFC %.4f K; growth %.5f K/s (expected 0.006)\n", r0, num / den);
    for (std::size_t i = 0; i < t.size(); ++i)
        std::printf("  t %.1f s after FFC: drift part %.4f K\n", t[i], g[i]);
    EXPECT_NEAR(num / den, 0.3 * 0.02, 0.10 * 0.3 * 0.02);
    EXPECT_GT(g.back(), 5.0 * netd_K);  // by then the pattern is far above the noise
}

// The FFC removes offsets only: the residual gain pattern (σ_g = 0.2 %, preset) shows in
// proportion to the scene's signal less the shutter's. In counts at 300 K's 50 counts/K, with
// the scene through the lens (τ = 0.9) and the shutter before it (τ = 1, at T_fpa = 293.15 K):
// Δ = 50·(0.9·L(350 K) − L(293.15 K))/(0.9·dL/dT(300 K)), σ = √((σ_g·Δ)² + σ_noise²), σ_noise
// the noise of the two averages as above (NETD·√(1/20 + 1/60), in counts).
TEST(Ffc, GainPatternShowsInProportionToTheScenesDifferenceFromTheShutter) {
    const ThermalCameraParams cam =
        test::thermalPreset("boson-640", {{"width", "128"},
                                          {"height", "96"},
                                          {"focal_plane.self_heating_K", "0"},
                                          {"noise.flicker_rel", "0"}});
    BolometerChain chain(cam, 6);
    const ImageF scene = test::blackbody(cam, 350.0);
    test::pastStartupFfc(chain, scene, 10);
    const double delta = 50.0 *
                         (0.9 * planckBandRadiance_W_m2_sr(7.5, 13.5, 350.0) -
                          planckBandRadiance_W_m2_sr(7.5, 13.5, 293.15)) /
                         (0.9 * planckBandRadianceDerivative_W_m2_sr_K(7.5, 13.5, 300.0));
    const double noise = 0.040 * 50.0 * std::sqrt(1.0 / 20.0 + 1.0 / 60.0);
    const double expected = std::sqrt(0.002 * delta * 0.002 * delta + noise * noise) / 50.0;
    const double r = residualFpn_K(chain, scene, 60);
    std::printf("350 K scene after FFC: pattern %.4f K, expected %.4f K\n", r, expected);
    EXPECT_NEAR(r, expected, 0.10 * expected);
}

// Without a shutter (shutterless cores) nothing is frozen and nothing removes the offsets: the
// pattern is the preset's offset σ, 2 K (with the 0.2 % gain pattern times the 300 K scene's
// 0.9·L(300) against its calibration, and the noise of a 60-frame mean, both < 1 % of it).
TEST(Ffc, WithoutAShutterTheOffsetPatternStays) {
    const ThermalCameraParams cam =
        test::thermalPreset("boson-640", {{"width", "128"},
                                          {"height", "96"},
                                          {"shutter.enabled", "false"},
                                          {"focal_plane.self_heating_K", "0"},
                                          {"noise.flicker_rel", "0"}});
    BolometerChain chain(cam, 7);
    const ImageF scene = test::blackbody(cam, 300.0);
    EXPECT_FALSE(chain.process(scene.cview()).frozen);
    const double r = residualFpn_K(chain, scene, 60);
    EXPECT_NEAR(r, 2.0, 0.05 * 2.0);
    EXPECT_EQ(chain.lastInfo().ffc_count, 0u);
}

TEST(Ffc, TemperatureChangeStartsTheNextOneAndRestoresTheResidual) {
    const ThermalCameraParams cam = driftingCamera();
    BolometerChain chain(cam, 4);
    const ImageF scene = test::blackbody(cam, 300.0);
    test::pastStartupFfc(chain, scene, 0);
    // The start-up FFC began at t = 0 with T_fpa = ambient; at 0.02 K/s, |ΔT| reaches 1.5 K at
    // 75 s: the next FFC starts with the first frame at or after 75 s.
    double started_s = -1.0;
    for (int k = 0; k < 80 * 60 && started_s < 0.0; ++k)
        if (chain.process(scene.cview()).ffc_started) started_s = chain.lastInfo().t_s;
    EXPECT_NEAR(started_s, 75.0, 1.0 / 60.0 + 1e-9);
    EXPECT_EQ(chain.lastInfo().ffc_count, 1u);  // the start-up one; this one is under way
    while (chain.process(scene.cview()).frozen) {
    }
    EXPECT_EQ(chain.lastInfo().ffc_count, 2u);
    EXPECT_LT(residualFpn_K(chain, scene, 60), 0.040);
}

TEST(Ffc, ClosedFramesAreFrozenAndFlagged) {
    const ThermalCameraParams cam = test::thermalPreset(
        "boson-320", {{"width", "64"}, {"height", "48"}, {"shutter.interval_s", "2.0"}});
    BolometerChain chain(cam, 8);
    ImageF scene = test::blackbody(cam, 300.0);
    for (int y = 10; y < 20; ++y)
        for (int x = 10; x < 30; ++x)
            scene(x, y) = static_cast<float>(
                planckBandRadiance_W_m2_sr(cam.band_lo_um, cam.band_hi_um, 310.0));
    // Start-up: 12 closed frames and 2 settling ones after (preset), nothing good to show yet.
    int frozen = 0, closed = 0;
    while (chain.process(scene.cview()).frozen) {
        ++frozen;
        closed += chain.lastInfo().shutter_closed ? 1 : 0;
    }
    EXPECT_EQ(closed, cam.ffc_closed_frames);
    EXPECT_EQ(frozen, cam.ffc_closed_frames + cam.ffc_settle_frames);
    // Run to the interval FFC; each closed frame repeats the last good frame's bits.
    ImageU16 lastRaw(cam.width, cam.height);
    ImageU8 lastDisplay(cam.width, cam.height);
    int closedRun = 0, runs = 0;
    for (int k = 0; k < 150; ++k) {
        const FrameInfo& info = chain.process(scene.cview());
        if (info.frozen) {
            ++closedRun;
            EXPECT_EQ(info.ffc_started, closedRun == 1);
            for (int y = 0; y < cam.height; ++y) {
                ASSERT_EQ(0, std::memcmp(chain.raw().row(y), lastRaw.row(y), 2 * cam.width));
                ASSERT_EQ(0, std::memcmp(chain.display().row(y), lastDisplay.row(y), cam.width));
            }
        } else {
            if (closedRun > 0) {
                EXPECT_EQ(closedRun, cam.ffc_closed_frames + cam.ffc_settle_frames);
                ++runs;
                // No flash of the shutter's level: the lag has settled (e^(−3·33/10) of the
                // shutter's 300 K − 293 K difference, ~350 counts, is 0.02 counts), so the first
                // frame shown matches the last one before within noise (0.05 counts of a mean).
                EXPECT_NEAR(test::meanRaw(chain.raw()), test::meanRaw(lastRaw), 0.5);
            }
            closedRun = 0;
            lastRaw.copyFrom(chain.raw().cview());
            lastDisplay.copyFrom(chain.display().cview());
        }
    }
    // Started at t = 2 s (frame 60 of 30 Hz) and 4 s: two FFCs in frames 14 … 163.
    EXPECT_EQ(runs, 2);
}

}  // namespace
}  // namespace nvs::bolometer
