// Photon transfer through the whole chain (EMVA 1288 release 4.0, §6: the variance of a
// uniform field against its mean). For an intensified camera each photoelectron is multiplied
// by the MCP with excess noise factor F and lands as a spot of the system PSF, so
//     σ²(S) = K·F·NEA·S + σ₀²,
// K the declared DC per photoelectron (CameraParams::dcPerPhotoelectron), NEA = Σ psf² the
// noise-equivalent area of the blur (1 without MTF), computed here independently as the mean of
// MTF² over the sampled frequencies (Parseval), and σ₀² the signal-independent floor. The
// chain's slope must agree with K·F·NEA within 5 %, with the MTF on and off; and the preset's σ
// at the means of the thesis's Table 18-5 (5.5 V, uniform calibration field) within 30 % of the
// measured σ.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <vector>

#include "sim/core/csv.h"
#include "sim/core/planck.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"
#include "sim/sensor/mtf.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace nvs::sensor {
namespace {

using test::preset;

// Afterglow shorter than a field: each field independent (the temporal filter of the
// phosphor is a separate effect, tested in chain_test).
Overrides fastScreen(bool mtf) {
    return {{"width", "256"},
            {"height", "256"},
            {"video.scan", "frame"},
            {"optics.cos4", "false"},
            {"photocathode.ebi_lm_cm2", "0"},
            {"halo.enabled", "false"},
            {"mcp_saturation.enabled", "false"},
            {"phosphor.decay_s", "[1.0e-5]"},
            {"phosphor.weight", "[1.0]"},
            {"mtf.enabled", mtf ? "true" : "false"},
            {"ccd.full_well_e", "0"},
            {"video.adc_bits", "12"}};
}

// Mean and variance of the output [DC above the offset] for a uniform input giving `n_pe`
// photoelectrons per pixel and field on average, over several fields.
test::Stats measure(const CameraParams& cam, double n_pe, int fields = 4) {
    const double t_s = cam.integrationPeriod_s();
    const float lpe = static_cast<float>(n_pe / (cam.peRatePerLpe_on_axis() * t_s));
    const ImageF in = test::uniform(cam.width, cam.height, lpe);
    IiccdChain chain(cam, 7, test::configDir(), test::gammaTables());
    double mean = 0.0, var = 0.0;
    const int m = 24;  // keep clear of the FFT's wrap-around at the edges
    for (int k = 0; k < fields; ++k) {
        (void)chain.process(in.cview());
        const test::Stats s =
            test::roiStats(chain.counts().cview(), m, m, cam.width - 2 * m, cam.height - 2 * m);
        mean += s.mean - cam.video_offset_dc;
        var += s.var;
    }
    return {mean / fields, var / fields};
}

// NEA = Σ psf² = mean of MTF² over the pixel-sampled frequency square (Parseval).
double noiseEquivalentArea(const CameraParams& cam) {
    if (!cam.mtf_enabled) return 1.0;
    const int n = 256;
    const double dx = cathodePitchX_mm(cam), dy = cathodePitchY_mm(cam);
    double s = 0.0;
    for (int j = 0; j < n; ++j)
        for (int i = 0; i < n; ++i) {
            const double fx = (i < n / 2 ? i : i - n) / (n * dx);
            const double fy = (j < n / 2 ? j : j - n) / (n * dy);
            const double m = systemMtf(cam, fx, fy);
            s += m * m;
        }
    return s / (static_cast<double>(n) * n);
}

double slope(const CameraParams& cam, double nLow, double nHigh, test::Stats* lo, test::Stats* hi) {
    *lo = measure(cam, nLow);
    *hi = measure(cam, nHigh);
    return (hi->var - lo->var) / (hi->mean - lo->mean);
}

// A decay much shorter than the gate: the in-period fraction is 1 − τ/g, not 0·∞ (it was NaN
// for g/τ beyond ~710, and so was every pixel of a chain with such a screen).
TEST(ChainPhotonTransferScreen, ShortDecayIsFiniteAndEmittedInItsPeriod) {
    const double g = 1.0 / 59.94;
    const double f = PhosphorStage::inPeriodFraction(1e-5, g, g);
    EXPECT_NEAR(f, 1.0 - 1e-5 / g, 1e-9);
    const double fShort = PhosphorStage::inPeriodFraction(1e-5, 1e-3, g);  // gate ≪ period
    EXPECT_NEAR(fShort, 1.0, 1e-12);
    // Long decay against the closed form of a small x.
    EXPECT_NEAR(PhosphorStage::inPeriodFraction(1.0, g, g), 1.0 - std::exp(-g) * std::expm1(g) / g,
                1e-12);
}

class ChainPhotonTransfer : public ::testing::TestWithParam<const char*> {};

TEST_P(ChainPhotonTransfer, SlopeIsDeclaredGainTimesExcessNoiseTimesNea) {
    for (const bool mtf : {false, true}) {
        CameraParams cam = preset(GetParam(), fastScreen(mtf));
        const double gain_V = 5.5;
        cam.gain_V = gain_V;
        const double k = cam.dcPerPhotoelectron(gain_V);
        const double nea = noiseEquivalentArea(cam);
        // Levels a few hundred DC apart, well inside the 16-bit range.
        const double nLow = 20.0 / k, nHigh = 400.0 / k;
        test::Stats lo, hi;
        const double got = slope(cam, nLow, nHigh, &lo, &hi);
        const double want = k * cam.mcp_noise_factor * nea;
        std::printf("%s mtf %d: K %.4g DC/pe, F %.3g, NEA %.4g: slope %.4g (want %.4g)\n",
                    GetParam(), mtf ? 1 : 0, k, cam.mcp_noise_factor, nea, got, want);
        EXPECT_NEAR(got / want, 1.0, 0.05) << (mtf ? "MTF on" : "MTF off");
        // The mean follows K exactly (no noise in the mean beyond its sampling error).
        EXPECT_NEAR(hi.mean / (nHigh * k), 1.0, 0.01);
    }
}

INSTANTIATE_TEST_SUITE_P(Presets, ChainPhotonTransfer,
                         ::testing::Values("pulnix-ag5745ef3", "gen2-s25-p20"));

// Table 18-6's image bias [DC] at a gain control voltage.
double table18_6Bias_dc(double gain_V) {
    const CsvTable t = CsvTable::load(test::thesisData("table18-6_camera_gain_vs_image_gain.csv"));
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        if (std::fabs(t.number(r, t.column("camera_gain_V")) - gain_V) < 1e-9)
            return t.number(r, t.column("image_bias_DC"));
    }
    ADD_FAILURE() << "no Table 18-6 row at " << gain_V << " V";
    return 0.0;
}

// Table 18-5: twenty frames of the uniform calibration field at 5.5 V, mean and σ in DC (the
// bias, 29.8 DC at 5.5 V, Table 18-6, included in the mean). The preset, with everything on,
// fed a uniform input that gives each measured mean, must give σ within 30 %.
TEST(ChainPhotonTransferThesis, Table18_5SigmaWithin30Percent) {
    const CsvTable t =
        CsvTable::load(test::thesisData("table18-5_radiometric_calibration_gain5p5V.csv"));
    // The frames went through the thesis's grabber: its blur is part of their noise.
    Overrides ov{{"width", "256"}, {"height", "256"}};
    test::addThesisGrabber(ov);
    CameraParams cam = preset("pulnix-ag5745ef3", ov);
    cam.gain_V = 5.5;
    // The frames' bias at 5.5 V is Table 18-6's (29.8 DC), not the preset's offset (the bias
    // extrapolated to zero tube gain): the signal above it is what the tube gave.
    const double bias_dc = table18_6Bias_dc(5.5);
    const double k = cam.dcPerPhotoelectron(cam.gain_V);
    std::printf(
        "qe_peak %.4g, S_k %.4g uA/lm, G(5.5 V) %.4g (channel %.4g), K %.4g DC/pe, luminous gain "
        "%.4g fL/fc at 5.5 V, %.4g at 6 V\n",
        cam.qe_peak, cam.cathode_sensitivity_uA_lm, cam.mcpGain(5.5), cam.mcpChannelGain(5.5), k,
        cam.luminousGain_fL_fc(5.5), cam.luminousGain_fL_fc(6.0));
    double worst = 0.0;
    for (std::size_t r = 0; r < t.rowCount(); r += 3) {
        const double mean = t.number(r, t.column("mean_DC"));
        const double sd = t.number(r, t.column("stddev_DC"));
        const double s = mean - bias_dc;
        ASSERT_GT(s, 0.0);
        // Field scan: statistics over the rows of the field read out; enough fields for the
        // afterglow to reach its steady state.
        const double t_s = cam.integrationPeriod_s();
        const float lpe = static_cast<float>(s / k / (cam.peRatePerLpe_on_axis() * t_s));
        const ImageF in = test::uniform(cam.width, cam.height, lpe);
        IiccdChain chain(cam, 11, test::configDir(), test::gammaTables());
        for (int f = 0; f < 40; ++f)
            (void)chain.process(in.cview());
        test::Stats st = test::roiStats(chain.counts().cview(), 24, 24, 208, 208);
        st.mean += bias_dc - cam.video_offset_dc;  // the model's offset is the zero-gain bias
        const double ratio = st.sd() / sd;
        std::printf(
            "Table 18-5 frame %s: mean %.2f (model %.2f), sd %.2f (model %.2f) ratio %.2f\n",
            t.row(r)[t.column("frame_no")].c_str(), mean, st.mean, sd, st.sd(), ratio);
        EXPECT_NEAR(st.mean, mean, 0.05 * s + 1.0);
        worst = std::max(worst, std::fabs(ratio - 1.0));
    }
    EXPECT_LT(worst, 0.30);
}

// The contradiction, measured (docs/validation.md, "Tube gain"). Table 18-5 gives each frame's
// mean and the sphere's reduced radiance (2856 K, band 480–940 nm). The preset's physics (lens,
// transmission, photocathode QE from its luminous sensitivity) turns that radiance into
// photoelectrons per pixel and field; the frame's mean above the bias divided by them is the DC
// per photoelectron the radiance calibration implies. Photon transfer (the same frames' σ) says
// K(5.5 V) = dcPerPhotoelectron. They differ by the factor the docs state: about 8.
TEST(ChainPhotonTransferThesis, RadianceCalibrationImpliesFewerPhotoelectronsPerDc) {
    const CsvTable t =
        CsvTable::load(test::thesisData("table18-5_radiometric_calibration_gain5p5V.csv"));
    // Table 18-5 was taken at f/11 (Appendix H §18.4; tests/data/thesis/README.md), not at the
    // preset's f/5.6.
    const CameraParams cam = preset("pulnix-ag5745ef3", {{"f_number", "11"}});
    const Spectrum box =
        Spectrum::fromFunction([](double nm) { return nm >= 480.0 && nm <= 940.0 ? 1.0 : 0.0; });
    const double lpePerL = peRadiancePerBandRadiance(cam, planckRadiance_W_m2_sr_nm(2856.0), box);
    const double bias_dc = table18_6Bias_dc(5.5);
    double sumRatio = 0.0;
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        const double L = t.number(r, t.column("reduced_radiance_W_m-2_sr-1"));
        const double s = t.number(r, t.column("mean_DC")) - bias_dc;
        const double pe = L * lpePerL * cam.peRatePerLpe_on_axis() * cam.integrationPeriod_s();
        sumRatio += (s / pe) / cam.dcPerPhotoelectron(5.5);
    }
    const double ratio = sumRatio / static_cast<double>(t.rowCount());
    std::printf(
        "Table 18-5: radiance calibration %.4g DC/pe vs photon transfer %.4g DC/pe: x%.1f\n",
        ratio * cam.dcPerPhotoelectron(5.5), cam.dcPerPhotoelectron(5.5), ratio);
    // Photon transfer through the thesis's grabber (K 2.52x the grabber-less 5.6 DC/pe) leaves
    // ×7.8; the bounds hold ±30 % (the ND densities' spread, docs/validation.md).
    EXPECT_GT(ratio, 5.5);
    EXPECT_LT(ratio, 10.0);
}

// The Gen III preset's luminous gain (cathode sensitivity, MCP law with its ceiling, screen),
// measured as MIL-I-49428 specifies (screen luminance in fL per fc on the cathode):
// - at the AGC's 9 V maximum it is the thesis's 15 000 (Appendix A, Table 11-1), read as
//   cd m⁻² lx⁻¹ (x π in fL/fc), and lies in the range of Gen III tubes' maximum gain, 2e4-8e4;
// - its ratios at 6 and 6.5 V to 5.5 V are Table 18-6's measured image-gain ratios (2.5, 5)
//   within 10 %;
// - the MCP's channel gain rises with voltage up to the supply's plate ceiling and is flat
//   above it, where the gain is Appendix A's.
TEST(ChainPhotonTransferThesis, GenIIILuminousGainAtAppendixAsMaximumAndTable18_6Ratios) {
    const CameraParams cam = preset("pulnix-ag5745ef3");
    for (const double v : {5.0, 5.5, 6.0, 6.5, 7.8, 9.0}) {
        std::printf(
            "pulnix at %.1f V: luminous gain %.4g fL/fc, MCP channel gain %.4g, %.4g MCP "
            "electrons per photoelectron, K %.4g DC/pe\n",
            v, cam.luminousGain_fL_fc(v), cam.mcpChannelGain(v), cam.mcpGain(v),
            cam.dcPerPhotoelectron(v));
    }
    const double g9 = cam.luminousGain_fL_fc(9.0);
    EXPECT_NEAR(g9, 15000.0 * 3.14159265358979, 0.01 * g9);
    EXPECT_GT(g9, 2e4);
    EXPECT_LT(g9, 8e4);
    const CsvTable t = CsvTable::load(test::thesisData("table18-6_camera_gain_vs_image_gain.csv"));
    const auto imageGain = [&](double v) {
        for (std::size_t r = 0; r < t.rowCount(); ++r) {
            if (std::fabs(t.number(r, t.column("camera_gain_V")) - v) < 1e-9)
                return t.number(r, t.column("image_gain_f11_DC_per_W_m-2_sr-1"));
        }
        ADD_FAILURE() << "no Table 18-6 row at " << v << " V";
        return 1.0;
    };
    for (const double v : {6.0, 6.5}) {
        const double model = cam.luminousGain_fL_fc(v) / cam.luminousGain_fL_fc(5.5);
        const double measured = imageGain(v) / imageGain(5.5);
        std::printf("gain ratio %.1f V : 5.5 V: model %.3f, Table 18-6 %.3f\n", v, model, measured);
        EXPECT_NEAR(model / measured, 1.0, 0.10) << v << " V";
    }
    // Eq. 6.1's ratio 6.5 V : 6 V is (1275/1180)^10 = 2.17 below the ceiling; from the ceiling
    // on (Vm = plate_max_V) the gain is the 9 V gain.
    double previous = 0.0;
    for (double v = 3.5; v <= 9.0; v += 0.5) {
        const double ch = cam.mcpChannelGain(v);
        const double vm = cam.mcp_offset_V + cam.mcp_V_per_control_V * v;
        if (vm < cam.mcp_plate_max_V) {
            EXPECT_GT(ch, previous) << v << " V";
        } else {
            EXPECT_EQ(cam.luminousGain_fL_fc(v), g9) << v << " V";
        }
        previous = ch;
    }
    EXPECT_NEAR(cam.luminousGain_fL_fc(6.5) / cam.luminousGain_fL_fc(6.0),
                std::pow(1275.0 / 1180.0, 10.0), 1e-9);
    // The derivation reproduces the anchor it was given.
    EXPECT_NEAR(cam.luminousGain_fL_fc(cam.luminous_gain_control_V), cam.luminous_gain_fL_fc,
                1e-6 * cam.luminous_gain_fL_fc);
}

}  // namespace
}  // namespace nvs::sensor
