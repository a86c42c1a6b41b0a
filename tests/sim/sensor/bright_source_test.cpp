// Bright sources on an intensifier: the halo (photoelectrons backscattered at the MCP land
// within 2× the cathode–MCP gap) and MCP local saturation (a channel gives at most the charge
// its wall holds, recharged with τ). Against their laws: the halo kernel's support and rim, the
// share displaced, charge conservation; the saturation curve Q·(1 − e^(−D/Q)) and the
// exponential recharge across fields; and the saturated area of a lamp of growing intensity,
// which is bounded by the halo disk widened by the blur of a charge-limited disk.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "sim/core/units.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"
#include "sim/sensor/mtf.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace nvs::sensor {
namespace {

using test::preset;

// Veiling glare as ISO 9358 measures it: a uniform field with a small black spot; the spot's
// image receives g · (the field's illuminance) · (1 − a) / (1 − g·a), a the spot's share of the
// image (the veil is g times the image's mean; the field keeps 1 − g of its own). The optics'
// total rate is kept. cos⁴θ off so that the field is uniform.
TEST(Optics, VeilingGlareIndexIsTheBlackSpotsShareOfAUniformField) {
    const double g = 0.03;
    const CameraParams cam = test::preset(
        "pulnix-ag5745ef3", {{"optics.veiling_glare_index", "0.03"}, {"optics.cos4", "false"}});
    const CameraParams plain = test::preset("pulnix-ag5745ef3", {{"optics.cos4", "false"}});
    ImageF lpe(cam.width, cam.height);
    lpe.fill(1.0e12f);
    const int s = 40, x0 = cam.width / 2 - s / 2, y0 = cam.height / 2 - s / 2;
    for (int y = y0; y < y0 + s; ++y)
        for (int x = x0; x < x0 + s; ++x)
            lpe(x, y) = 0.0f;
    ImageF veiled(cam.width, cam.height), bare(cam.width, cam.height);
    FieldContext c1, c2;
    OpticsStage(cam).apply(lpe.cview(), veiled.view(), c1);
    OpticsStage(plain).apply(lpe.cview(), bare.view(), c2);
    const double a = static_cast<double>(s * s) / (cam.width * cam.height);
    const double spot = static_cast<double>(veiled(x0 + s / 2, y0 + s / 2));
    const double field = static_cast<double>(veiled(10, 10));
    const double want = g * (1.0 - a) / (1.0 - g * a);
    double sumV = 0.0, sumB = 0.0;
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x)
            sumV += static_cast<double>(veiled(x, y)), sumB += static_cast<double>(bare(x, y));
    std::printf(
        "veiling glare index %.3f: black spot / field %.6f (ISO 9358: %.6f); total "
        "rate ratio %.8f\n",
        g, spot / field, want, sumV / sumB);
    EXPECT_NEAR(spot / field, want, 1e-5);
    EXPECT_NEAR(sumV / sumB, 1.0, 1e-6);
    EXPECT_EQ(bare(x0 + s / 2, y0 + s / 2), 0.0f);  // without it the spot is black
}

TEST(Halo, KernelIsADiskOfTwiceTheGapDensestAtItsRim) {
    const CameraParams cam = preset("pulnix-ag5745ef3");
    ASSERT_TRUE(cam.halo_enabled);
    const HaloStage halo(cam);
    const int kr = halo.kernelRadiusCells();
    const int n = 2 * kr + 1;
    double sum = 0.0;
    for (float k : halo.kernel())
        sum += static_cast<double>(k);
    EXPECT_NEAR(sum, 1.0, 1e-5);
    // Support: cells whose nearest point is beyond R = 2·gap carry nothing.
    const double cx_um = HaloStage::kBlock * cam.pitch_x_um * cam.taper_magnification;
    const double cy_um = HaloStage::kBlock * cam.pitch_y_um * cam.taper_magnification;
    const double r_um = 2.0 * cam.halo_gap_um;
    EXPECT_DOUBLE_EQ(cam.haloRadius_um(), r_um);
    double rimW = 0.0, midW = 0.0;
    int rimN = 0, midN = 0;
    for (int j = -kr; j <= kr; ++j)
        for (int i = -kr; i <= kr; ++i) {
            const float k = halo.kernel()[static_cast<std::size_t>((j + kr) * n + (i + kr))];
            const double nearX = std::max(0.0, (std::abs(i) - 0.5) * cx_um);
            const double nearY = std::max(0.0, (std::abs(j) - 0.5) * cy_um);
            if (std::hypot(nearX, nearY) >= r_um) {
                EXPECT_EQ(k, 0.0f) << i << "," << j;
            }
            const double u = std::hypot(i * cx_um, j * cy_um) / r_um;
            if (u > 0.75 && u < 0.9) rimW += static_cast<double>(k), ++rimN;
            if (u > 0.3 && u < 0.45) midW += static_cast<double>(k), ++midN;
        }
    ASSERT_GT(rimN, 0);
    ASSERT_GT(midN, 0);
    // p(r) ∝ 1/√(1 − u²) per unit r, i.e. per area ∝ 1/(u√(1 − u²)): at u ≈ 0.83 vs 0.38 the
    // per-cell weight is ≈ 0.82× (the 1/u), not the 2.2× a uniform disk's r would give.
    const double ratio = (rimW / rimN) / (midW / midN);
    const double want = (1.0 / (0.825 * std::sqrt(1.0 - 0.825 * 0.825))) /
                        (1.0 / (0.375 * std::sqrt(1.0 - 0.375 * 0.375)));
    EXPECT_NEAR(ratio, want, 0.15 * want);
}

TEST(Halo, DisplacesItsShareAndConservesTheTotal) {
    CameraParams cam = preset("pulnix-ag5745ef3", {{"width", "256"}, {"height", "256"}});
    HaloStage halo(cam);
    ImageF rate(256, 256);
    rate.fill(0.0f);
    for (int y = 128; y < 132; ++y)  // one whole cell: the point source's image
        for (int x = 128; x < 132; ++x)
            rate.view()(x, y) = 1000.0f;
    halo.apply(rate.view());
    double total = 0.0, core = 0.0;
    for (int y = 0; y < 256; ++y)
        for (int x = 0; x < 256; ++x) {
            const double v = static_cast<double>(rate.cview()(x, y));
            total += v;
            if (x >= 128 && x < 132 && y >= 128 && y < 132) core += v;
        }
    EXPECT_NEAR(total, 16000.0, 0.5);  // far from the borders: nothing leaves the frame
    // What stays: (1 − f) of the source plus the kernel's own centre cell.
    const double f = cam.halo_fraction;
    const int kr = halo.kernelRadiusCells();
    const double centre =
        static_cast<double>(halo.kernel()[static_cast<std::size_t>(kr * (2 * kr + 1) + kr)]);
    EXPECT_NEAR(core / 16000.0, (1.0 - f) + f * centre, 1e-4);
}

TEST(McpSaturation, OutputFollowsTheChargeLawAndRechargesWithTau) {
    CameraParams cam = preset("pulnix-ag5745ef3", {{"width", "8"}, {"height", "1"}});
    ASSERT_TRUE(cam.mcpsat_enabled);
    McpSaturationStage sat(cam);
    FieldContext ctx;
    ctx.period_s = 1.0 / 59.94;
    const double q = cam.mcpsat_pixel_charge_e;
    const double keep = std::exp(-ctx.period_s / cam.mcpsat_recharge_s);
    sat.begin(ctx);
    float row[8];
    const double demand[8] = {1.0, 10.0, 0.1 * q, 0.5 * q, q, 3.0 * q, 10.0 * q, 100.0 * q};
    for (int x = 0; x < 8; ++x)
        row[x] = static_cast<float>(demand[x]);
    (void)sat.applyRow(row, 8, 0);
    for (int x = 0; x < 8; ++x) {
        const double want = q * -std::expm1(-demand[x] / q);
        EXPECT_NEAR(static_cast<double>(row[x]), want, 1e-3 * want + 1e-3) << x;
        EXPECT_LE(static_cast<double>(row[x]), q * (1.0 + 1e-6));
    }
    // Dark fields after: the deficit decays by e^(−T/τ) each field.
    const double deficit0 = q - static_cast<double>(sat.charge().cview()(7, 0));
    EXPECT_NEAR(deficit0, q * keep, 1e-3 * q);  // emptied, then one period of recharge
    for (int k = 1; k <= 3; ++k) {
        float dark[8] = {};
        (void)sat.applyRow(dark, 8, 0);
        const double deficit = q - static_cast<double>(sat.charge().cview()(7, 0));
        EXPECT_NEAR(deficit, deficit0 * std::pow(keep, k), 1e-3 * q) << k;
    }
}

// Saturated area (CCD cells at full well, which the 8-bit video reaches first) of a 4×4 px lamp
// of intensity I photoelectrons per pixel and field, the whole chain on at 6 V.
std::int64_t lampArea(const CameraParams& cam, double pe) {
    ImageF in(cam.width, cam.height);
    in.fill(0.0f);
    const float lpe =
        static_cast<float>(pe / (cam.peRatePerLpe_on_axis() * cam.integrationPeriod_s()));
    for (int y = cam.height / 2 - 2; y < cam.height / 2 + 2; ++y)
        for (int x = cam.width / 2 - 2; x < cam.width / 2 + 2; ++x)
            in.view()(x, y) = lpe;
    IiccdChain chain(cam, 3, test::configDir(), test::gammaTables());
    for (int f = 0; f < 6; ++f)
        (void)chain.process(in.cview());
    return chain.lastInfo().saturated_px;
}

// The law: the MCP gives each pixel at most Q_max, so whatever I is, the charge reaching the CCD
// is at most A_disk·Q_max·η (A_disk the halo disk of radius R = 2·gap, η CCD electrons per MCP
// electron); blur and blooming can spread it, but at full well each cell holds FW, so the
// saturated area A(I) ≤ A_disk·(1 + Q_max·η/FW). A(I) grows while the disk fills and converges
// (A(10⁹)/A(10⁸) < 1.15: at 6 V the MCP gives 5 electrons per photoelectron, docs/validation.md
// "Tube gain", so the charge limit is reached at ~20× the photoelectrons that the former 113
// needed). Without the MCP's limit the overload grows with I and so does A.
TEST(BrightSource, SaturatedAreaOfALampConvergesAndStaysSmall) {
    CameraParams cam = preset("pulnix-ag5745ef3", {{"width", "256"}, {"height", "256"}});
    cam.gain_V = 6.0;
    std::int64_t prev = 0, a6 = 0, a7 = 0;  // at 10⁸ and 10⁹
    for (const double pe : {1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9}) {
        const std::int64_t area = lampArea(cam, pe);
        std::printf("lamp %.0e pe/px/field: %lld px at full well\n", pe,
                    static_cast<long long>(area));
        EXPECT_GE(area, prev) << pe;
        prev = area;
        if (pe == 1e8) a6 = area;
        if (pe == 1e9) a7 = area;
    }
    EXPECT_GT(a6, 16);  // the lamp's own image and more
    EXPECT_LT(static_cast<double>(a7) / static_cast<double>(a6), 1.15);
    const double rx = cam.haloRadius_um() / (cam.pitch_x_um * cam.taper_magnification);
    const double ry = cam.haloRadius_um() / (cam.pitch_y_um * cam.taper_magnification);
    const double disk = kPi * rx * ry;
    const double bound = disk * (1.0 + cam.mcpsat_pixel_charge_e *
                                           cam.ccdElectronsPerMcpElectron() / cam.full_well_e);
    std::printf("bound A_disk (%.0f px) x (1 + Q_max eta/FW) = %.0f px\n", disk, bound);
    EXPECT_LT(static_cast<double>(a7), bound);
    CameraParams linear = cam;
    linear.mcpsat_enabled = false;
    const std::int64_t b7 = lampArea(linear, 1e9);
    std::printf("lamp 1e+09 without MCP saturation: %lld px\n", static_cast<long long>(b7));
    EXPECT_GT(b7, 2 * a7);
}

}  // namespace
}  // namespace nvs::sensor
