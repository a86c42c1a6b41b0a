// Gain control to 8 bit against cases worked out by hand.

#include "sim/bolometer/stages/agc.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/bolometer/camera.h"
#include "sim/core/image.h"
#include "sim/core/planck.h"
#include "tests/sim/bolometer/bolometer_test_util.h"

namespace nvs::bolometer {
namespace {

ThermalCameraParams tiny(AgcMode mode, double plateauRel) {
    ThermalCameraParams cam;  // defaults; a 4 × 4 frame set directly
    cam.width = 4;
    cam.height = 4;
    cam.agc_mode = mode;
    cam.plateau_rel = plateauRel;
    cam.clip_low = 0.0;
    cam.clip_high = 1.0;
    return cam;
}

// 16 pixels: eight at 100, four at 101, two at 200, two at 5000.
ImageU16 handImage() {
    ImageU16 raw(4, 4);
    const std::uint16_t v[16] = {100, 100, 100, 100, 100, 100, 100,  100,
                                 101, 101, 101, 101, 200, 200, 5000, 5000};
    for (int i = 0; i < 16; ++i)
        raw(i % 4, i / 4) = v[i];
    return raw;
}

// Plateau P = round(3/16 · 16) = 3. Histogram h: 100 → 8, 101 → 4, 200 → 2, 5000 → 2.
// Clipped h' = min(h, 3): 3, 3, 2, 2. Cumulative C: 3, 6, 8, 10; C(v_min) = 3, C(v_max) = 10,
// out = round(255·(C − 3)/7): 100 → 0, 101 → round(109.29) = 109, 200 → round(182.14) = 182,
// 5000 → 255. (The 5000 outlier takes no more grey levels than the 200s: the plateau's point.)
TEST(Agc, PlateauEqualisationMatchesTheHandComputedCase) {
    const ThermalCameraParams cam = tiny(AgcMode::Plateau, 3.0 / 16.0);
    AgcStage agc(cam);
    const ImageU16 raw = handImage();
    ImageU8 out(4, 4);
    agc.apply(raw.cview(), out.view());
    EXPECT_EQ(out(0, 0), 0);
    EXPECT_EQ(out(0, 2), 109);
    EXPECT_EQ(out(0, 3), 182);
    EXPECT_EQ(out(2, 3), 255);
}

// A plateau above every bin is plain equalisation: C = 8, 12, 14, 16, C(v_min) = 8, span 8:
// 101 → round(255·4/8) = round(127.5) = 128, 200 → round(255·6/8) = round(191.25) = 191.
TEST(Agc, PlateauAboveEveryBinIsPlainEqualisation) {
    const ThermalCameraParams cam = tiny(AgcMode::Plateau, 1.0);
    AgcStage agc(cam);
    const ImageU16 raw = handImage();
    ImageU8 out(4, 4);
    agc.apply(raw.cview(), out.view());
    EXPECT_EQ(out(0, 0), 0);
    EXPECT_EQ(out(0, 2), 128);
    EXPECT_EQ(out(0, 3), 191);
    EXPECT_EQ(out(2, 3), 255);
}

// Linear with clip 0 / 1: lo = 1000, hi = 2500 (the extremes of 1000 + 100·i); 1700 →
// round(255·700/1500) = round(119.0) = 119. Damping: the next frame is 1000 counts brighter;
// lo moves by α = 1 − e^(−Δt/τ) = 1 − e^(−(1/30)/0.5) = 0.064493 of the way: 1064.49.
TEST(Agc, LinearMapsTheClipLevelsAndDampsThem) {
    ThermalCameraParams cam = tiny(AgcMode::Linear, 0.005);
    cam.frame_rate_Hz = 30.0;
    cam.agc_time_constant_s = 0.5;
    AgcStage agc(cam);
    ImageU16 raw(4, 4);
    for (int i = 0; i < 16; ++i)
        raw(i % 4, i / 4) = static_cast<std::uint16_t>(1000 + 100 * i);
    ImageU8 out(4, 4);
    agc.apply(raw.cview(), out.view());
    EXPECT_EQ(out(0, 0), 0);
    EXPECT_EQ(out(3, 1), 119);  // i = 7: 1700
    EXPECT_EQ(out(3, 3), 255);
    for (int i = 0; i < 16; ++i)
        raw(i % 4, i / 4) = static_cast<std::uint16_t>(2000 + 100 * i);
    agc.apply(raw.cview(), out.view());
    EXPECT_NEAR(agc.low_counts(), 1064.493, 0.01);
    EXPECT_NEAR(agc.high_counts(), 2564.493, 0.01);
}

// In the chain, on a scene of a 280–320 K ramp with a small 400 K object (9 pixels, 0.05 %):
// linear AGC with 0.5 % / 99.5 % clipping puts the ramp's ends near 0 and 255 and saturates the
// object; plateau equalisation gives the object 255 too, and spreads the ramp over the grey
// levels rather than compressing it below the object. (A 1000 K object would not do for the
// linear case: its blur halo, the Airy tails of 20× the ramp's radiance, lifts ~2 % of the
// pixels above 320 K and moves the 99.5 % percentile onto the halo; that is the optics' doing.)
TEST(Agc, BothModesShowARampBesideAHotObject) {
    for (const char* mode : {"linear", "plateau"}) {
        const ThermalCameraParams cam = test::thermalPreset(
            "boson-320", {{"width", "200"}, {"height", "100"}, {"agc.mode", mode}});
        BolometerChain chain(cam, 2);
        ImageF scene(cam.width, cam.height);
        for (int y = 0; y < cam.height; ++y)
            for (int x = 0; x < cam.width; ++x)
                scene(x, y) = static_cast<float>(planckBandRadiance_W_m2_sr(
                    7.5, 13.5,
                    (x >= 102 && x < 105 && y >= 52 && y < 55) ? 400.0 : 280.0 + 0.2 * x));
        test::pastStartupFfc(chain, scene, 30);
        const ImageU8& d = chain.display();
        double left = 0.0, right = 0.0, mid = 0.0;
        for (int y = 0; y < 40; ++y) {
            left += d(5, y) / 40.0;
            right += d(194, y) / 40.0;
            mid += d(100, y) / 40.0;
        }
        EXPECT_EQ(d(103, 53), 255) << mode;
        EXPECT_LT(left, 12.0) << mode;
        EXPECT_GT(right, 243.0) << mode;
        EXPECT_NEAR(mid, 127.5, 20.0) << mode;  // the ramp's middle near mid-grey
    }
}

}  // namespace
}  // namespace nvs::bolometer
