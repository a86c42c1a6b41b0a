// NETD as a laboratory measures it: a uniform blackbody fills the view, a pixel's temporal σ
// over many frames [counts] is divided by the measured response to a 1 K step of the blackbody
// [counts/K]. Expected values: the preset's datasheet NETD (FLIR Boson datasheet: < 40 mK at
// f/1.0), carried to the camera by the laws stated in each test. The 1/f noise is off here (it is
// not part of a datasheet NETD, which is measured over short records; flicker_test.cpp checks
// it), and so is the focal plane's self-heating (the offsets' slow drift would add to σ).

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "sim/core/planck.h"
#include "tests/sim/bolometer/bolometer_test_util.h"

namespace nvs::bolometer {
namespace {

struct NetdMeasurement {
    double netd_K;
    double response_counts_K;
};

NetdMeasurement measureNetd(const std::string& preset, double T_K, bool flicker = false,
                            const std::string& fNumber = "1.0") {
    Overrides ov{{"width", "96"},
                 {"height", "80"},
                 {"focal_plane.self_heating_K", "0"},
                 {"optics.f_number", fNumber}};
    if (!flicker) ov.emplace("noise.flicker_rel", "0");
    const ThermalCameraParams cam = test::thermalPreset(preset, ov);
    BolometerChain chain(cam, 11);
    const ImageF a = test::blackbody(cam, T_K);
    const ImageF b = test::blackbody(cam, T_K + 1.0);
    test::pastStartupFfc(chain, a, 10);
    test::PixelStats sa(static_cast<std::size_t>(cam.width * cam.height));
    for (int k = 0; k < 300; ++k) {
        EXPECT_FALSE(chain.process(a.cview()).frozen);
        sa.add(chain.raw());
    }
    // The 1 K step: 20 frames to settle (≥ 10 τ), then the mean of 100.
    for (int k = 0; k < 20; ++k)
        chain.process(b.cview());
    test::PixelStats sb(static_cast<std::size_t>(cam.width * cam.height));
    for (int k = 0; k < 100; ++k) {
        chain.process(b.cview());
        sb.add(chain.raw());
    }
    const double response = sb.grandMean() - sa.grandMean();
    return {std::sqrt(sa.meanTemporalVariance()) / response, response};
}

// The datasheet's NETD is the camera's at f/1.0 (a Boson core ships with its lens); the presets'
// lens is f/1.0, so the measured NETD must be the datasheet's.
constexpr double kDatasheetNetd_K = 0.040;
constexpr double kLensFactor = 1.0;

TEST(Netd, MeasuredFromFramesAtTheReferenceIsTheDatasheets) {
    const NetdMeasurement m = measureNetd("boson-640", 300.0);
    std::printf("boson-640 at 300 K: NETD %.4f K measured, %.4f K expected; %.2f counts/K\n",
                m.netd_K, kDatasheetNetd_K * kLensFactor, m.response_counts_K);
    EXPECT_NEAR(m.netd_K, kDatasheetNetd_K * kLensFactor, 0.10 * kDatasheetNetd_K * kLensFactor);
    // The response to a 1 K step at 300 K: the ADC's stated 50 counts/K (preset) times
    // (L(301) − L(300))/(dL/dT at 300 K), the band radiance being what the counts are linear in.
    const double lin = (planckBandRadiance_W_m2_sr(7.5, 13.5, 301.0) -
                        planckBandRadiance_W_m2_sr(7.5, 13.5, 300.0)) /
                       planckBandRadianceDerivative_W_m2_sr_K(7.5, 13.5, 300.0);
    EXPECT_NEAR(m.response_counts_K, 50.0 * lin, 0.02 * 50.0);
}

// Through a slower lens the noise [W] stays and the signal per kelvin falls with the cone's
// π/(1 + 4N²): NETD(f/1.4) = NETD(f/1.0)·(1 + 4·1.4²)/(1 + 4·1.0²) = 1.768× (Vollmer &
// Möllmann 2018, §2.4; the datasheet's "@ f/1.0" is why it names the f-number).
TEST(Netd, ScalesWithTheFNumber) {
    const NetdMeasurement m = measureNetd("boson-640", 300.0, false, "1.4");
    const double expected = kDatasheetNetd_K * (1.0 + 4.0 * 1.96) / 5.0;
    std::printf("boson-640 at f/1.4: NETD %.4f K measured, %.4f K expected\n", m.netd_K, expected);
    EXPECT_NEAR(m.netd_K, expected, 0.10 * expected);
}

// With the preset's 1/f noise on (σ 0.3 of NETD's, stationary): a 5 s record catches at most all
// of it, σ·√(1 + 0.09) = +4.4 %, so the measured NETD is still within 10 % of the datasheet's.
TEST(Netd, WithThePresetsOneOverFNoiseStillWithinTenPercent) {
    const NetdMeasurement m = measureNetd("boson-640", 300.0, true);
    std::printf("boson-640 at 300 K, 1/f on: NETD %.4f K\n", m.netd_K);
    EXPECT_NEAR(m.netd_K, kDatasheetNetd_K * kLensFactor, 0.10 * kDatasheetNetd_K * kLensFactor);
    EXPECT_LE(m.netd_K, kDatasheetNetd_K * kLensFactor * std::sqrt(1.09) * 1.02);
}

// Off the reference the noise [W] is the same and the signal per kelvin follows dL/dT, so
// NETD(T) = NETD(T_ref)·(dL/dT at T_ref)/(dL/dT at T): at 0 °C in 7.5–13.5 µm that is ~1.3×
// the 300 K figure, at 60 °C ~0.8× (the numbers come from Planck's law below).
TEST(Netd, ScalesWithTheBandRadianceDerivativeOffTheReference) {
    for (const double T_K : {273.15, 333.15}) {
        const NetdMeasurement m = measureNetd("boson-320", T_K);
        const double scale = planckBandRadianceDerivative_W_m2_sr_K(7.5, 13.5, 300.0) /
                             planckBandRadianceDerivative_W_m2_sr_K(7.5, 13.5, T_K + 0.5);
        const double expected = kDatasheetNetd_K * kLensFactor * scale;
        std::printf("boson-320 at %.2f K: NETD %.4f K measured, %.4f K expected\n", T_K, m.netd_K,
                    expected);
        EXPECT_NEAR(m.netd_K, expected, 0.10 * expected) << T_K;
        // and it is not the reference's figure (the test can tell the two apart)
        EXPECT_GT(std::abs(m.netd_K - kDatasheetNetd_K * kLensFactor), 0.12 * expected) << T_K;
    }
}

// Row and column noise as the 3-D noise model measures them (D'Agostino & Webb 1991): the
// temporal variance of a row's mean is σ_row² + (σ_px² + σ_col²)/W, of a column's mean
// σ_col² + (σ_px² + σ_row²)/H, with σ_row = σ_col = 0.15·σ and σ_px² = (1 − 2·0.15²)·σ² (preset),
// σ the NETD in counts (0.040 K × 50 counts/K at 300 K; + 1/12 count² of quantisation in σ_px²).
TEST(Netd, RowAndColumnNoiseAsTheThreeDNoiseModelMeasuresThem) {
    const ThermalCameraParams cam =
        test::thermalPreset("boson-640", {{"width", "96"},
                                          {"height", "80"},
                                          {"noise.flicker_rel", "0"},
                                          {"focal_plane.self_heating_K", "0"}});
    BolometerChain chain(cam, 13);
    const ImageF scene = test::blackbody(cam, 300.0);
    test::pastStartupFfc(chain, scene, 5);
    const int W = cam.width, H = cam.height, n = 400;
    std::vector<double> rs(H, 0.0), rs2(H, 0.0), cs(W, 0.0), cs2(W, 0.0);
    for (int k = 0; k < n; ++k) {
        chain.process(scene.cview());
        std::vector<double> col(W, 0.0);
        for (int y = 0; y < H; ++y) {
            double row = 0.0;
            for (int x = 0; x < W; ++x) {
                row += chain.raw()(x, y);
                col[x] += chain.raw()(x, y);
            }
            rs[y] += row / W;
            rs2[y] += (row / W) * (row / W);
        }
        for (int x = 0; x < W; ++x) {
            cs[x] += col[x] / H;
            cs2[x] += (col[x] / H) * (col[x] / H);
        }
    }
    double vRow = 0.0, vCol = 0.0;
    for (int y = 0; y < H; ++y)
        vRow += (rs2[y] - rs[y] * rs[y] / n) / (n - 1) / H;
    for (int x = 0; x < W; ++x)
        vCol += (cs2[x] - cs[x] * cs[x] / n) / (n - 1) / W;
    const double s2 = 0.040 * 50.0 * 0.040 * 50.0;
    const double px2 = (1.0 - 2.0 * 0.15 * 0.15) * s2 + 1.0 / 12.0, rc2 = 0.15 * 0.15 * s2;
    const double eRow = rc2 + (px2 + rc2) / W, eCol = rc2 + (px2 + rc2) / H;
    std::printf(
        "row-mean variance %.4f (expected %.4f), column-mean %.4f (expected %.4f) "
        "counts²\n",
        vRow, eRow, vCol, eCol);
    EXPECT_NEAR(vRow, eRow, 0.10 * eRow);
    EXPECT_NEAR(vCol, eCol, 0.10 * eCol);
    // Without them the row means would vary by σ_px²/W only, a third of this.
    EXPECT_GT(vRow, 2.0 * px2 / W);
}

}  // namespace
}  // namespace nvs::bolometer
