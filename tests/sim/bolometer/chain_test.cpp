// The chain's contract: 14-bit raw range with clipping counted, determinism (same seed → same
// bits), bad input counted, size mismatch refused; and the optics' MTF against the
// diffraction-limited law.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>

#include "sim/core/planck.h"
#include "tests/sim/bolometer/bolometer_test_util.h"

namespace nvs::bolometer {
namespace {

ThermalCameraParams small(const std::string& preset, Overrides ov = {}) {
    ov.emplace("width", "64");
    ov.emplace("height", "48");
    return test::thermalPreset(preset, ov);
}

TEST(Chain, RawStaysInFourteenBitsAndCountsClipping) {
    const ThermalCameraParams cam = small("boson-640");
    BolometerChain chain(cam, 1);
    ImageF scene = test::blackbody(cam, 300.0);
    const float hot = static_cast<float>(planckBandRadiance_W_m2_sr(7.5, 13.5, 1000.0));
    for (int y = 0; y < 16; ++y)
        for (int x = 0; x < 64; ++x)
            scene(x, y) = y < 6 ? hot : 0.0f;  // 1000 K, then a 0 K (no radiance) band
    test::pastStartupFfc(chain, scene, 3);
    const FrameInfo& info = chain.lastInfo();
    EXPECT_GT(info.clipped_px, 0);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x)
            EXPECT_LE(chain.raw()(x, y), 16383);
    for (int x = 0; x < cam.width; ++x)
        EXPECT_EQ(chain.raw()(x, 1), 16383);  // the 1000 K rows saturate
    // No radiance at all gives level − k·V_ref = 8192 − 50·L(300 K)/(dL/dT at 300 K): counts
    // are linear in band radiance (a uniform 0 K view, so that no blur mixes levels).
    const double zeroLevel = 8192.0 - 50.0 * planckBandRadiance_W_m2_sr(7.5, 13.5, 300.0) /
                                          planckBandRadianceDerivative_W_m2_sr_K(7.5, 13.5, 300.0);
    BolometerChain dark(cam, 1);
    const ImageF none(cam.width, cam.height);
    test::pastStartupFfc(dark, none, 10);
    EXPECT_NEAR(test::meanRaw(dark.raw()), zeroLevel, 2.0);
    // A 300 K blackbody sits at the preset's mid-scale level (8192 counts) within 3 counts.
    BolometerChain flat(cam, 1);
    const ImageF bb = test::blackbody(cam, 300.0);
    test::pastStartupFfc(flat, bb, 10);
    EXPECT_NEAR(test::meanRaw(flat.raw()), 8192.0, 3.0);
}

TEST(Chain, SameSeedSameBitsOtherSeedOtherBits) {
    const ThermalCameraParams cam = small("boson-320", {{"shutter.interval_s", "1.0"}});
    BolometerChain a(cam, 42), b(cam, 42), c(cam, 43);
    ImageF scene = test::blackbody(cam, 295.0);
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x)
            scene(x, y) *= 1.0f + 0.01f * static_cast<float>((x * 7 + y * 3) % 11);
    bool differs = false;
    for (int k = 0; k < 70; ++k) {  // start-up FFC and an interval FFC at 1 s
        a.process(scene.cview());
        b.process(scene.cview());
        c.process(scene.cview());
        for (int y = 0; y < cam.height; ++y) {
            ASSERT_EQ(0, std::memcmp(a.raw().row(y), b.raw().row(y), 2 * cam.width)) << k;
            ASSERT_EQ(0, std::memcmp(a.display().row(y), b.display().row(y), cam.width)) << k;
            differs = differs || std::memcmp(a.raw().row(y), c.raw().row(y), 2 * cam.width) != 0;
        }
    }
    EXPECT_TRUE(differs);
    EXPECT_EQ(a.lastInfo().ffc_count, 2u);
}

TEST(Chain, BadPixelsAreCountedAndWrongSizeRefused) {
    const ThermalCameraParams cam = small("boson-640");
    BolometerChain chain(cam, 1);
    ImageF scene = test::blackbody(cam, 300.0);
    test::pastStartupFfc(chain, scene, 0);
    scene(1, 1) = std::numeric_limits<float>::quiet_NaN();
    scene(2, 1) = -1.0f;
    scene(3, 1) = std::numeric_limits<float>::infinity();
    EXPECT_EQ(chain.process(scene.cview()).bad_input_px, 3);
    ImageF wrong(32, 48);
    EXPECT_TRUE(chain.process(wrong.cview()).size_mismatch);
}

// The MTF of a sampled diffraction-limited system along x at ν = 1/(8 px). The kernel is the
// PSF sampled at the pixel pitch p, so by Poisson's summation its transform at (ν, 0) is
// Σ_{mx, my} MTF(ν + mx/p, my/p), and it sums to 1, so that is divided by Σ MTF(mx/p, my/p);
// MTF(νx, νy) = MTF_diff(|ν|)·sinc(a νx)·sinc(a νy), a = p·√FF, MTF_diff of a circular pupil
// (Goodman, Introduction to Fourier Optics, §6.3) averaged over 7.5–13.5 µm with a 300 K
// blackbody's weight — written out here, apart from the code. Aliases past |m| = 1 are zero
// (the f/1 cut-off at 7.5 µm, 133 cycles/mm, is below 2/p = 167 cycles/mm).
constexpr double kPi = 3.14159265358979323846;
double diffractionLaw(double rho_cyc_m, double N) {
    double num = 0.0, den = 0.0;
    for (int i = 0; i <= 600; ++i) {  // trapezoid, 10 nm steps
        const double lam = (7.5 + 0.01 * i) * 1e-6;
        const double w =
            (i == 0 || i == 600 ? 0.5 : 1.0) * planckSpectralRadiance_W_m2_sr_m(lam, 300.0);
        const double s = rho_cyc_m * lam * N;
        const double m = s >= 1.0 ? 0.0 : 2.0 / kPi * (std::acos(s) - s * std::sqrt(1.0 - s * s));
        num += w * m;
        den += w;
    }
    return num / den;
}
double sincLaw(double x) {
    return x == 0.0 ? 1.0 : std::sin(kPi * x) / (kPi * x);
}
double sampledTransfer(double nu, double p, double a) {
    double num = 0.0, den = 0.0;
    for (int mx = -1; mx <= 1; ++mx)
        for (int my = -1; my <= 1; ++my) {
            const double vx = nu + mx / p, vy = my / p;
            num += diffractionLaw(std::hypot(vx, vy), 1.0) * sincLaw(a * vx) * sincLaw(a * vy);
            den +=
                diffractionLaw(std::hypot(mx / p, vy), 1.0) * sincLaw(a * mx / p) * sincLaw(a * vy);
        }
    return num / den;
}

double modulationAt(int period) {
    const ThermalCameraParams cam = small("boson-640");
    OpticsStage optics(cam, {});
    ImageF in(cam.width, cam.height), out(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x)
            in(x, y) = static_cast<float>(10.0 + 5.0 * std::cos(2.0 * kPi * x / period));
    optics.apply(in.cview(), out.view());
    // Amplitude by projection on cos over whole periods away from the edges (x = 16 … 47).
    double c = 0.0, m = 0.0;
    for (int x = 16; x < 48; ++x) {
        c += static_cast<double>(out(x, 24)) * std::cos(2.0 * kPi * x / period);
        m += static_cast<double>(out(x, 24));
    }
    return (c / 16.0) / (m / 32.0) / 0.5;  // against the input's 5/10
}

TEST(Optics, SineModulationFollowsTheDiffractionAndPixelMtf) {
    const double p = 12e-6, a = p * std::sqrt(0.8);
    for (int period : {4, 8, 16}) {
        const double law = sampledTransfer(1.0 / (period * p), p, a);
        EXPECT_NEAR(modulationAt(period), law, 0.005) << period;
        std::printf("period %d px: modulation %.4f, law %.4f\n", period, modulationAt(period), law);
    }
    EXPECT_LT(modulationAt(4), 0.8);  // the blur is there
}

}  // namespace
}  // namespace nvs::bolometer
