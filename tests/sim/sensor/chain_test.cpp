// The chain against physics and the thesis: MTF (slanted edge, Table 18-2), calibration
// (Tables 18-5, 18-6), temporal behaviour (phosphor decay, AGC/ABC/BSP/auto-gate), bad input.

#include "sim/sensor/chain.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <vector>

#include "sim/core/csv.h"
#include "sim/core/error.h"
#include "sim/core/planck.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/mtf.h"
#include "sim/sensor/sfr.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace nvs::sensor {
namespace {

using test::preset;
using test::roiStats;

// Noise-free linear chain: the electrons are a deterministic function of the input.
Overrides noiseFree() {
    return {{"photocathode.shot_noise", "false"},
            {"mcp.noise", "false"},
            {"ccd.read_noise_e", "0"},
            {"ccd.full_well_e", "0"},
            {"optics.cos4", "false"},
            {"photocathode.ebi_lm_cm2", "0"},
            {"video.adc_bits", "16"}};
}

// An area-sampled edge at `angle` from vertical through the image centre: each pixel holds the
// fraction of its area on the bright side (16 × 16 sub-samples).
ImageF slantedEdge(int w, int h, double angle_rad, float dark, float bright) {
    ImageF img(w, h);
    const double t = std::tan(angle_rad);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            int in = 0;
            for (int j = 0; j < 16; ++j)
                for (int i = 0; i < 16; ++i) {
                    const double px = x + (i + 0.5) / 16.0, py = y + (j + 0.5) / 16.0;
                    in += (px - 0.5 * w) > (py - 0.5 * h) * t ? 1 : 0;
                }
            img(x, y) = dark + (bright - dark) * static_cast<float>(in / 256.0);
        }
    return img;
}

// Measures the chain's horizontal SFR from a 5° slanted edge; returns the SFR with the
// input's own pixel-area MTF divided out, and the edge angle.
SfrResult measureSfr(const CameraParams& cam) {
    IiccdChain chain(cam, 1, test::configDir(), test::gammaTables());
    const ImageF in =
        slantedEdge(cam.width, cam.height, 5.0 * 3.14159265358979 / 180.0, 1e11f, 5e11f);
    chain.process(in.cview());
    // Wide enough for the heavy-tailed PSF of eq. 7.7 (n = 0.8) to settle on both sides.
    const int rw = 320, rh = 200;
    const ImageView<const float> roi =
        chain.electrons().cview().region(cam.width / 2 - rw / 2, cam.height / 2 - rh / 2, rw, rh);
    SfrResult r = slantedEdgeSfr(roi);
    const double c = std::cos(r.edgeAngle_rad), s = std::sin(r.edgeAngle_rad);
    for (std::size_t i = 0; i < r.sfr.size(); ++i) {
        const double f = r.frequency_cyc_px[i];
        r.sfr[i] /= mtfAperture(f * c, 1.0) * mtfAperture(f * s, 1.0);
    }
    return r;
}

TEST(Mtf, SlantedEdgeEqualsConfiguredProductUpToNyquist) {
    // The physical presets. (eq. 7.7's n = 0.8 has a PSF too heavy-tailed for a 320 px ROI.)
    for (const char* name : {"pulnix-ag5745ef3", "gen2-s25-p20"}) {
        Overrides ov = noiseFree();
        ov["video.noise_dc"] = "0";
        const CameraParams cam = preset(name, ov);
        const SfrResult r = measureSfr(cam);
        const double c = std::cos(r.edgeAngle_rad), s = std::sin(r.edgeAngle_rad);
        double worst = 0.0;
        for (double f = 0.025; f <= 0.5 + 1e-9; f += 0.025) {
            // Along the edge normal (cos, −sin) in pixels, converted to cyc/mm at the cathode.
            const double want =
                systemMtf(cam, f * c / cathodePitchX_mm(cam), -f * s / cathodePitchY_mm(cam));
            const double got = sfrAt(r, f);
            // 5 % of the configured value, with a floor of 0.005 in MTF units where the
            // MTF is small: the area-sampled target aliases ~0.005 near Nyquist.
            worst = std::max(worst, std::fabs(got - want) / want);
            EXPECT_LE(std::fabs(got - want), 0.05 * want + 0.005)
                << name << " f=" << f << " measured " << got << " configured " << want;
        }
        std::printf("%s: slanted-edge SFR vs configured MTF, worst relative error %.3f\n", name,
                    worst);
    }
}

TEST(Mtf, ReproducesThesisTable18_2) {
    const CameraParams cam = test::calibrationTube(noiseFree());
    const SfrResult r = measureSfr(cam);
    CsvTable t = CsvTable::load(test::thesisData("table18-2_electronic_mtf.csv"));
    const std::size_t cf = t.column("image_frequency_cyc_per_mm"), cm = t.column("mtf_rel");
    double ss = 0.0;
    for (std::size_t i = 0; i < t.rowCount(); ++i) {
        const double f_mm = t.number(i, cf);
        const double got = sfrAt(r, f_mm * cathodePitchX_mm(cam));
        const double want = t.number(i, cm);
        std::printf("Table 18-2: %.2f cyc/mm measured %.2f, chain %.3f\n", f_mm, want, got);
        // Scatter of the measured points about a smooth curve is ~0.02-0.03 (docs/sensor.md);
        // 0.05 is twice it.
        EXPECT_NEAR(got, want, 0.05) << f_mm;
        ss += (got - want) * (got - want);
    }
    std::printf("Table 18-2 rms residual %.3f\n",
                std::sqrt(ss / static_cast<double>(t.rowCount())));
}

// Counts vs radiance: Table 18-6 (gain at f/11, bias) and Table 18-5 (5.5 V points).
// Radiances are the thesis's band integrals over 480-940 nm of the sphere (a 2856 K lamp).
double meanCounts(CameraParams cam, double L_W_m2_sr) {
    const Spectrum box =
        Spectrum::fromFunction([](double nm) { return nm >= 480.0 && nm <= 940.0 ? 1.0 : 0.0; });
    const double k = peRadiancePerBandRadiance(cam, planckRadiance_W_m2_sr_nm(2856.0), box);
    cam.width = 128;
    cam.height = 96;
    IiccdChain chain(cam, 21, test::configDir(), test::gammaTables());
    const ImageF in = test::uniform(cam.width, cam.height, static_cast<float>(L_W_m2_sr * k));
    for (int i = 0; i < 12; ++i)  // both fields written, phosphor afterglow at steady state
        chain.process(in.cview());
    double s = 0.0;
    for (int i = 0; i < 4; ++i) {
        chain.process(in.cview());
        s += roiStats(chain.counts().cview(), 0, 0, cam.width, cam.height).mean;
    }
    return s / 4.0;
}

TEST(Calibration, Table18_6GainAndBias) {
    CsvTable t = CsvTable::load(test::thesisData("table18-6_camera_gain_vs_image_gain.csv"));
    for (std::size_t i = 0; i < t.rowCount(); ++i) {
        const double v = t.number(i, t.column("camera_gain_V"));
        if (v < 5.4) continue;  // the 5.0 V row is the thesis's estimate, not a measurement
        // 16-bit ADC so the mean is not clipped by the 8-bit range (docs/sensor.md), and no
        // full well: the preset's 60 000 e is assumed, not measured, and at 6.5 V the noisiest
        // cells of L2 pass it; the interline drain removes that charge (column blooming kept it
        // in the mean), while the thesis measured a linear response there.
        const CameraParams cam = test::calibrationTube({{"gain_V", std::to_string(v)},
                                                        {"f_number", "11"},
                                                        {"optics.cos4", "false"},
                                                        {"video.adc_bits", "16"},
                                                        {"ccd.full_well_e", "0"}});
        const double L1 = 2e-6, L2 = 8e-6;
        const double c0 = meanCounts(cam, 0.0), c1 = meanCounts(cam, L1), c2 = meanCounts(cam, L2);
        const double gain = (c2 - c1) / (L2 - L1);
        const double wantGain = t.number(i, t.column("image_gain_f11_DC_per_W_m-2_sr-1"));
        const double wantBias = t.number(i, t.column("image_bias_DC"));
        std::printf("Table 18-6 %.1f V: image gain %.3g (thesis %.3g), bias %.2f (thesis %.2f)\n",
                    v, gain, wantGain, c0, wantBias);
        // The printed gains have one significant figure (4e6, 10e6, 20e6): ±12 %.
        EXPECT_NEAR(gain / wantGain, 1.0, 0.12) << v;
        EXPECT_NEAR(c0, wantBias, 1.5) << v;
    }
}

TEST(Calibration, Table18_5PointsWithinScatter) {
    CsvTable t = CsvTable::load(test::thesisData("table18-5_radiometric_calibration_gain5p5V.csv"));
    const CameraParams cam = test::calibrationTube({{"gain_V", "5.5"},
                                                    {"f_number", "11"},
                                                    {"optics.cos4", "false"},
                                                    {"video.adc_bits", "16"}});
    // Scatter: frames at one filter setting differ by up to 25 DC (frames 17-20), and the
    // thesis's own calibration line (4e6, 29.8) misses frames 15-16 by 13 % and frame 17 by
    // 14 %. Each point within 25 %, the rms within 8 DC.
    double ss = 0.0;
    for (std::size_t i = 0; i < t.rowCount(); ++i) {
        const double L = t.number(i, t.column("reduced_radiance_W_m-2_sr-1"));
        const double want = t.number(i, t.column("mean_DC"));
        const double got = meanCounts(cam, L);
        ss += (got - want) * (got - want);
        EXPECT_NEAR(got, want, 0.25 * want) << "frame " << i + 1;
    }
    const double rms = std::sqrt(ss / static_cast<double>(t.rowCount()));
    std::printf("Table 18-5: rms residual %.2f DC over %zu frames\n", rms, t.rowCount());
    EXPECT_LT(rms, 8.0);
}

// Temporal: a step of light shows the phosphor's multi-exponential decay across fields
// (`tolerance` relative: the store's own rounding is part of it).
void checkPhosphorDecay(Overrides ov, double tolerance) {
    ov["width"] = "64";
    ov["height"] = "48";
    ov["mtf.enabled"] = "false";
    const CameraParams cam = test::calibrationTube(ov);
    IiccdChain chain(cam, 1, test::configDir(), test::gammaTables());
    const ImageF on = test::uniform(64, 48, 1e11f), off = test::uniform(64, 48, 0.0f);
    std::vector<double> out;
    for (int k = 0; k < 40; ++k) {
        chain.process((k < 30 ? on : off).cview());
        out.push_back(static_cast<double>(chain.electrons()(10, 10)));
    }
    const double steady = out[29];
    // Independent expectation: integrate each exponential's emission numerically over the
    // field windows, with the excitation spread over the whole field.
    const double T = cam.integrationPeriod_s();
    auto emittedInField = [&](double tau, int n) {  // field n after the last lit field
        const int steps = 2000;
        double acc = 0.0;
        for (int i = 0; i < steps; ++i) {  // excitation at t0 in the last lit field
            const double t0 = (i + 0.5) / steps * T;
            const double a = (n + 1) * T - t0, b = (n + 2) * T - t0;  // window of field n
            acc += std::exp(-a / tau) - std::exp(-b / tau);
        }
        return acc / steps;
    };
    for (int n = 0; n < 4; ++n) {
        double want = 0.0;
        for (int i = 0; i < 3; ++i) {  // all earlier lit fields add geometric copies
            const double tau = cam.phosphor_decay_s[static_cast<std::size_t>(i)];
            const double perField = std::exp(-T / tau);
            want += cam.phosphor_weight[static_cast<std::size_t>(i)] * emittedInField(tau, n) /
                    (1.0 - perField);
        }
        const double got = out[static_cast<std::size_t>(30 + n)] / steady;
        std::printf("phosphor afterglow field +%d: %.5f (expected %.5f)\n", n + 1, got, want);
        EXPECT_NEAR(got, want, tolerance * want + 1e-6);
    }
    // Light turned on: the first field lacks the afterglow the steady state has.
    EXPECT_LT(out[0], steady);
    // By superposition the first lit field lacks exactly the afterglow the first dark field
    // has.
    EXPECT_NEAR(out[0] / steady, 1.0 - out[30] / steady, 1e-4);
}

TEST(Temporal, PhosphorDecayAcrossFields) {
    // The reference's midpoint rule (2000 steps, h = 0.08 τ for the 0.1 ms component) is good
    // to ~3e-4 relative; the chain's float state to ~1e-6.
    checkPhosphorDecay(noiseFree(), 1e-3);
}

// The same with MCP saturation on, so that the store is binary16 (PhosphorStage::boundInput;
// each store rounded to 2^−12 relative, the steady store's error ~2^−12/(1 − d) at most). A
// channel charge well above this test's signal keeps saturation out of the ratios; the store's
// scale follows from it, and a charge 1e3× higher still passes, 1e6× higher does not (stores
// below 2^−27 of the bound are kept to an absolute 2^−38 of it: docs/sensor.md).
TEST(Temporal, PhosphorDecayAcrossFieldsWithAHalfPrecisionStore) {
    Overrides ov = noiseFree();
    ov["mcp_saturation.enabled"] = "true";
    ov["mcp_saturation.pixel_charge_e"] = "1e6";
    checkPhosphorDecay(ov, 2e-3);
}

// A lamp switched on in view at field 10.
struct LampRun {
    std::vector<FieldInfo> info;
};
LampRun lampRun(const Overrides& extra) {
    Overrides ov = noiseFree();
    ov["width"] = "128";
    ov["height"] = "96";
    ov["mtf.enabled"] = "false";
    ov["phosphor.enabled"] = "false";
    for (const auto& [k, v] : extra)
        ov[k] = v;
    const CameraParams cam = test::calibrationTube(ov);
    IiccdChain chain(cam, 1, test::configDir(), test::gammaTables());
    ImageF scene = test::uniform(128, 96, 3e12f);
    ImageF lamp = scene;
    for (int y = 30; y < 60; ++y)
        for (int x = 40; x < 80; ++x)
            lamp(x, y) = 3e14f;
    LampRun r;
    for (int k = 0; k < 60; ++k)
        r.info.push_back(chain.process((k < 10 ? scene : lamp).cview()));
    return r;
}

TEST(Temporal, AgcLagAndTimeConstant) {
    const LampRun r = lampRun({{"agc", "agc"}, {"agc_loop.target_dc", "60"}});
    for (int k = 7; k < 14; ++k)
        std::printf("AGC field %d: gain %.3f V level %.2f DC\n", k,
                    r.info[static_cast<std::size_t>(k)].gain_V,
                    r.info[static_cast<std::size_t>(k)].level_dc);
    const double T = 1.0 / 59.94, tau = 0.2;
    // One-field lag: the lamp's field still has the gain commanded from the dark field before
    // it (still rising toward the dark scene's target); the field after it is the first to fall.
    const double v9 = r.info[9].gain_V;
    EXPECT_GT(r.info[10].gain_V, v9);
    EXPECT_LT(r.info[11].gain_V, r.info[10].gain_V);
    // Time constant: the gain converges as (1 − α)^k with α = 1 − exp(−T/τ).
    const double vInf = r.info[59].gain_V;
    const double ratio = (r.info[21].gain_V - vInf) / (r.info[20].gain_V - vInf);
    std::printf(
        "AGC: V %.3f (before) %.3f (lamp field) %.3f %.3f ... %.3f; per-field ratio %.4f "
        "(expect %.4f)\n",
        v9, r.info[10].gain_V, r.info[11].gain_V, r.info[12].gain_V, vInf, ratio,
        std::exp(-T / tau));
    EXPECT_NEAR(ratio, std::exp(-T / tau), 0.01);
    EXPECT_NEAR(r.info[59].level_dc, 60.0, 2.0);
}

TEST(Temporal, AbcBspAndAutogate) {
    const LampRun abc = lampRun({{"agc", "abc"}, {"abc.screen_limit_A", "5e-10"}});
    std::printf("ABC: screen current %.3g A -> gain %.3f V, %.3f V, %.3f V ... %.3f V\n",
                abc.info[10].screen_current_A, abc.info[10].gain_V, abc.info[11].gain_V,
                abc.info[12].gain_V, abc.info[59].gain_V);
    EXPECT_NEAR(abc.info[10].gain_V, abc.info[9].gain_V, 1e-9);
    EXPECT_LT(abc.info[11].gain_V, abc.info[10].gain_V);
    EXPECT_NEAR(abc.info[59].screen_current_A, 5e-10, 0.1 * 5e-10);
    const LampRun bsp = lampRun({{"agc", "bsp"}, {"bsp.knee_A", "1e-13"}});
    std::printf("BSP: factor %.3f before, %.3f with the lamp (same field)\n",
                bsp.info[9].bsp_factor, bsp.info[10].bsp_factor);
    EXPECT_LT(bsp.info[10].bsp_factor, 0.5 * bsp.info[9].bsp_factor);  // no lag
    EXPECT_NEAR(bsp.info[11].bsp_factor, bsp.info[10].bsp_factor, 1e-9);
    const LampRun gate = lampRun({{"agc", "autogate"}, {"agc_loop.target_dc", "60"}});
    std::printf("auto-gate: gate %.4g s before, %.4g s lamp field, %.4g s next, %.4g s final\n",
                gate.info[9].gate_s, gate.info[10].gate_s, gate.info[11].gate_s,
                gate.info[59].gate_s);
    EXPECT_NEAR(gate.info[10].gate_s, gate.info[9].gate_s, 1e-12);
    EXPECT_LT(gate.info[11].gate_s, gate.info[10].gate_s);
    EXPECT_LT(gate.info[59].gate_s, 0.7 * gate.info[9].gate_s);
    EXPECT_NEAR(gate.info[59].level_dc, 60.0, 3.0);
    EXPECT_NEAR(gate.info[59].gain_V, gate.info[9].gain_V, 1e-12);
}

// Bright-source protection on the photoelectron count (bsp.acts_on = "photoelectrons", a gate
// whose duty cycle falls) against on the MCP's gain (the default): the same mean level; a shot
// noise per DC larger by 1/factor (fewer photoelectrons, each amplified as before), equal to
// that of the camera without protection given the light times the factor (a gate of duty
// cycle f is that much less light), against which the gain member's is f times as large.
TEST(Temporal, BspOnThePhotoelectronsIsLessLightNotLessGain) {
    Overrides ov = {{"width", "64"},          {"height", "64"},
                    {"video.scan", "frame"},  {"ccd.read_noise_e", "0"},
                    {"video.noise_dc", "0"},  {"video.adc_bits", "16"},
                    {"ccd.full_well_e", "0"}, {"photocathode.ebi_lm_cm2", "0"},
                    {"ccd.prnu_rel", "0"},    {"agc", "bsp"}};
    const float level = 2e13f;
    auto stats = [&](const Overrides& o, float light, double& mean, double& var, double& f) {
        const CameraParams cam = preset("pulnix-ag5745ef3", o);
        IiccdChain chain(cam, 3, test::configDir(), test::gammaTables());
        const ImageF in = test::uniform(64, 64, light);
        std::vector<ImageF> frames;
        for (int k = 0; k < 24; ++k) {
            f = chain.process(in.cview()).bsp_factor;
            frames.push_back(chain.counts());
        }
        double s = 0.0, d2 = 0.0, n = 0.0;
        for (int k = 5; k < 24; ++k)
            for (int y = 8; y < 56; ++y)
                for (int x = 8; x < 56; ++x) {
                    s += static_cast<double>(frames[k](x, y)) - cam.video_offset_dc;
                    const double d = static_cast<double>(frames[k](x, y)) -
                                     static_cast<double>(frames[k - 1](x, y));
                    d2 += d * d;
                    n += 1.0;
                }
        mean = s / n;
        var = d2 / (2.0 * n);
    };
    // The knee where this light's cathode current halves the gain, found from a run without it.
    double m0 = 0.0, v0 = 0.0, f0 = 0.0;
    Overrides probe = ov;
    probe["bsp.knee_A"] = "1";
    stats(probe, level, m0, v0, f0);
    const CameraParams cam = preset("pulnix-ag5745ef3", probe);
    IiccdChain c(cam, 3, test::configDir(), test::gammaTables());
    const double i_A = c.process(test::uniform(64, 64, level).cview()).cathode_current_A;
    char knee[32];
    std::snprintf(knee, sizeof knee, "%.9g", i_A / 1.5);  // factor 1/(1 + 1.5) = 0.4
    ov["bsp.knee_A"] = knee;
    double mg = 0.0, vg = 0.0, fg = 0.0, mp = 0.0, vp = 0.0, fp = 0.0;
    stats(ov, level, mg, vg, fg);
    Overrides pe = ov;
    pe["bsp.acts_on"] = "photoelectrons";
    stats(pe, level, mp, vp, fp);
    double ml = 0.0, vl = 0.0, fl = 0.0;
    stats(probe, static_cast<float>(static_cast<double>(level) * fg), ml, vl, fl);
    std::printf(
        "factor %.3f: mean %.2f (gain) %.2f (photoelectrons) %.2f (less light); "
        "variance per DC %.3f, %.3f, %.3f\n",
        fg, mg, mp, ml, vg / mg, vp / mp, vl / ml);
    EXPECT_NEAR(fg, 0.4, 0.01);
    EXPECT_NEAR(fp, fg, 1e-9);
    EXPECT_NEAR(mp / mg, 1.0, 0.01);
    EXPECT_NEAR(ml / mg, 1.0, 0.02);
    EXPECT_NEAR((vp / mp) / (vl / ml), 1.0, 0.08);
    EXPECT_NEAR((vg / mg) / (vl / ml), fg, 0.08 * fg);
    EXPECT_THROW(test::calibrationTube({{"bsp.acts_on", "screen"}}), SetupError);
}

// Optics: the camera equation's off-axis fall-off cos⁴θ, cos θ = f/√(f² + r²) with r the
// distance from the axis on the cathode, computed here in double; bad pixels count and give 0.
TEST(Optics, Cos4FalloffEqualsTheCameraEquation) {
    const CameraParams cam = test::calibrationTube();
    OpticsStage optics(cam);
    ImageF in = test::uniform(cam.width, cam.height, 1e10f);
    in(3, 4) = std::nanf("");
    in(5, 6) = -1.0f;
    ImageF rate(cam.width, cam.height);
    FieldContext ctx;
    EXPECT_EQ(optics.apply(in.cview(), rate.view(), ctx), 2);
    EXPECT_EQ(rate(3, 4), 0.0f);
    EXPECT_EQ(rate(5, 6), 0.0f);
    const double f_m = cam.focal_length_mm * 1e-3;
    const double px_m = cam.pitch_x_um * 1e-6 * cam.taper_magnification;
    const double py_m = cam.pitch_y_um * 1e-6 * cam.taper_magnification;
    double worst = 0.0, sum = 0.0;
    for (int y = 0; y < cam.height; ++y) {
        for (int x = 0; x < cam.width; ++x) {
            const double dx = (x - 0.5 * (cam.width - 1)) * px_m;
            const double dy = (y - 0.5 * (cam.height - 1)) * py_m;
            const double c2 = f_m * f_m / (f_m * f_m + dx * dx + dy * dy);
            const double want = 1e10 * cam.peRatePerLpe_on_axis() * c2 * c2;
            sum += static_cast<double>(rate(x, y));
            if ((x == 3 && y == 4) || (x == 5 && y == 6)) continue;
            worst = std::max(worst, std::fabs(static_cast<double>(rate(x, y)) / want - 1.0));
        }
    }
    EXPECT_LT(worst, 1e-6);
    EXPECT_NEAR(ctx.cathodeRate_pe_s, sum, 1e-6 * sum);
    // The corner of the 768 x 494 cells (11 x 13 um) behind the 1.636x taper, at f = 36 mm:
    // r = 9.6 mm on the cathode, tan θ = 0.27, cos⁴θ = 0.893.
    const double corner = static_cast<double>(rate(0, 0) / rate(cam.width / 2, cam.height / 2));
    EXPECT_NEAR(corner, 0.893, 0.002);
}

TEST(Ccd, BloomingConservesChargeAndStreaks) {
    std::vector<float> v(20, 10.0f), carry(42);
    v[10] = 500.0f;
    double before = 0.0;
    for (float x : v)
        before += static_cast<double>(x);
    const auto sat = CcdStage::bloomLine(v.data(), 20, 1, 100.0f, carry.data());
    double after = 0.0;
    for (float x : v)
        after += static_cast<double>(x);
    EXPECT_NEAR(after, before, 1e-3);
    EXPECT_EQ(sat, 5);  // 500 + 4·10 → 5 cells of 100 (plus the 60 left over beside them)
    EXPECT_EQ(v[10], 100.0f);
    EXPECT_EQ(v[8], 100.0f);
    EXPECT_EQ(v[12], 100.0f);
}

// Vertical blooming in the chain (all columns swept together, row by row) equals
// bloomLine applied column by column, and conserves charge.
TEST(Ccd, VerticalBloomingOfTheImageEqualsBloomLinePerColumn) {
    CameraParams cam = test::calibrationTube({{"width", "40"}, {"height", "30"}});
    cam.read_noise_e = 0.0;
    cam.full_well_e = 100.0;
    cam.architecture = CcdArchitecture::FullFrame;  // no overflow drain: the overload blooms
    cam.bloom = BloomDirection::Vertical;
    cam.smear_rel = 0.0;
    CcdStage ccd(cam, 1);
    ImageF img = test::uniform(40, 30, 10.0f);
    img(5, 3) = 900.0f;  // streak reaching the top edge (charge drained there)
    img(5, 20) = 300.0f;
    img(17, 15) = 2000.0f;
    img(18, 15) = 150.0f;
    img(39, 29) = 450.0f;
    ImageF ref = img;
    std::vector<float> carry(2 * 30 + 2);
    std::int64_t satRef = 0;
    for (int x = 0; x < 40; ++x)
        satRef += CcdStage::bloomLine(ref.row(0) + x, 30, ref.stride_px(), 100.0f, carry.data());
    FieldContext ctx;
    ctx.period_s = 1.0 / 59.94;
    const std::int64_t sat = ccd.apply(img.view(), ctx);
    EXPECT_EQ(sat, satRef);
    for (int y = 0; y < 30; ++y)
        for (int x = 0; x < 40; ++x)
            ASSERT_NEAR(img(x, y), ref(x, y), 1e-3f) << x << "," << y;
    // Charge: 2000 + 29·10 in column 17 fits (30 cells × 100 = 3000): conserved exactly.
    double col17 = 0.0;
    for (int y = 0; y < 30; ++y)
        col17 += static_cast<double>(img(17, y));
    EXPECT_NEAR(col17, 2000.0 + 29 * 10.0, 1e-2);
}

// An interline CCD (vertical overflow drain) under the datasheet's smear condition (Sony's
// 1/10 V method: a bright area 1/10 of the height; Sm = 20·log(smear / signal)): the cells
// under the light hold full well (the drain takes the rest, nothing spreads to the columns
// beside it), and every cell of those columns carries smear = signal · 10^(Sm/20).
TEST(Ccd, InterlineDrainsTheOverloadAndSmearsAtTheDatasheetRatio) {
    constexpr int w = 40, h = 100;
    const double smear_dB = -100.0;
    CameraParams cam = test::calibrationTube({{"width", "40"},
                                              {"height", "100"},
                                              {"ccd.architecture", "\"interline\""},
                                              {"ccd.smear_dB", "-100.0"},
                                              {"ccd.read_noise_e", "0.0"},
                                              {"ccd.full_well_e", "1000.0"}});
    ASSERT_EQ(cam.architecture, CcdArchitecture::Interline);
    CcdStage ccd(cam, 1);
    ImageF img = test::uniform(w, h, 0.0f);
    const float signal_e = 50000.0f;  // 50× full well, well inside the drain's capacity
    for (int y = 40; y < 40 + h / 10; ++y)
        for (int x = 10; x < 30; ++x)
            img(x, y) = signal_e;
    FieldContext ctx;
    ctx.period_s = 1.0 / 59.94;
    const std::int64_t sat = ccd.apply(img.view(), ctx);
    EXPECT_EQ(sat, 20 * h / 10);
    const double smear_e = static_cast<double>(signal_e) * std::pow(10.0, smear_dB / 20.0);
    for (int x = 0; x < w; ++x) {
        const bool lit = x >= 10 && x < 30;
        for (int y = 0; y < h; ++y) {
            const bool core = lit && y >= 40 && y < 50;
            const double want = (core ? 1000.0 : 0.0) + (lit ? smear_e : 0.0);
            ASSERT_NEAR(img(x, y), want, 0.01 * smear_e) << x << "," << y;
        }
    }
}

// One cell 500× over full well: on an interline CCD the drain takes it (the cells above and
// below carry only the smear line, the columns beside it nothing); on a full-frame CCD (no
// drain) the same overload blooms along the column, filling ≈ 500 cells to full well.
TEST(Ccd, InterlineOverloadMakesASmearLineFullFrameBlooms) {
    constexpr int w = 9, h = 600;
    for (const char* arch : {"interline", "full_frame"}) {
        CameraParams cam =
            test::calibrationTube({{"width", "9"},
                                   {"height", "600"},
                                   {"ccd.architecture", std::string("\"") + arch + "\""},
                                   {"ccd.read_noise_e", "0.0"},
                                   {"ccd.full_well_e", "100.0"}});
        if (std::string(arch) == "interline") {
            cam.smear_rel = CcdParams::smearRelFromDb(-100.0);
        }
        CcdStage ccd(cam, 1);
        ImageF img = test::uniform(w, h, 0.0f);
        img(4, 300) = 50000.0f;
        FieldContext ctx;
        ctx.period_s = 1.0 / 59.94;
        const std::int64_t sat = ccd.apply(img.view(), ctx);
        for (int y = 0; y < h; ++y) {
            ASSERT_EQ(img(3, y), 0.0f) << arch << " y " << y;
            ASSERT_EQ(img(5, y), 0.0f) << arch << " y " << y;
        }
        if (std::string(arch) == "interline") {
            EXPECT_EQ(sat, 1);
            // 1/10 V smear ratio 1e-5 of a signal spread over 1/10 of the height: here the
            // column's light is 50000 e in one of 600 rows, 50000/60 e "per 1/10 height".
            const double smear_e = 50000.0 / (h / 10.0) * 1e-5;
            EXPECT_NEAR(img(4, 299), smear_e, 1e-3 * smear_e + 1e-6);
            EXPECT_NEAR(img(4, 0), smear_e, 1e-3 * smear_e + 1e-6);
            EXPECT_LT(img(4, 299), 0.01f);  // 0.008 e: a line far below one electron
        } else {
            EXPECT_NEAR(static_cast<double>(sat), 499.0, 1.0);  // 49 900 e over: 499 cells full
            EXPECT_EQ(img(4, 299), 100.0f);
            EXPECT_EQ(img(4, 301), 100.0f);
            EXPECT_EQ(img(4, 300 - 200), 100.0f);
        }
    }
}

// Each shipped preset states its CCD's architecture; the tube cameras' CCDs are interline.
TEST(Ccd, ShippedPresetsStateTheirArchitecture) {
    for (const char* name : {"pulnix-ag5745ef3", "pulnix-ag5745ef3-ccir", "gen2-s25-p20"}) {
        const CameraParams cam = test::preset(name);
        EXPECT_EQ(cam.architecture, CcdArchitecture::Interline) << name;
        EXPECT_GT(cam.smear_rel, 0.0) << name;
        EXPECT_LT(cam.smear_rel, 1e-3) << name;
    }
}

// Gamma: the video stage's table search gives round(span·(s/span)^γ + offset) clamped to the
// ADC range, computed here directly in double, for every signal on a fine ramp (values within
// 1e-4 DC of a rounding boundary may go either way: float signal).
TEST(Video, GammaTableEqualsTheFormula) {
    for (double gamma : {0.8, 0.45, 1.6}) {
        CameraParams cam = test::calibrationTube({{"width", "1000"}, {"height", "2"}});
        cam.gamma = gamma;
        cam.scan = ScanMode::Frame;
        VideoStage video(cam);
        ImageF e(1000, 2), counts(1000, 2);
        ImageU16 out(1000, 2);
        for (int y = 0; y < 2; ++y)
            for (int x = 0; x < 1000; ++x)  // −5 … 300 DC before the offset
                e(x, y) = static_cast<float>((-5.0 + 305.0 * (x + 1000 * y) / 2000.0) /
                                             cam.video_gain_dc_per_e);
        video.apply(e.cview(), 0, counts.view(), out.view());
        const double maxc = 255.0, offset = cam.video_offset_dc, span = maxc - offset;
        int checked = 0;
        for (int y = 0; y < 2; ++y)
            for (int x = 0; x < 1000; ++x) {
                const double sig = static_cast<double>(e(x, y)) *
                                   static_cast<double>(static_cast<float>(cam.video_gain_dc_per_e));
                double v = sig;
                if (sig > 0.0) v = span * std::pow(std::min(sig / span, 1.0), gamma);
                v += offset;
                const double frac = v - std::floor(v);
                if (std::fabs(frac - 0.5) < 1e-4) continue;
                const double want = std::clamp(std::nearbyint(v), 0.0, maxc);
                ASSERT_EQ(static_cast<double>(counts(x, y)), want)
                    << "gamma " << gamma << " signal " << sig;
                ASSERT_EQ(static_cast<double>(out(x, y)), want);
                ++checked;
            }
        EXPECT_GT(checked, 1990);
    }
}

// The droop of an AC-coupled video line (video.streak_fraction, streak_tau_px): a flat field
// through the whole chain comes out, along each line, as S·(1 − f·(1 − exp(−x/τ))), the step
// response of a first-order high-pass of weight f started at the line's start (the RC law),
// against the same chain without it. A bright bar then leaves the level after it below the
// flat line's, recovering toward it (a dark streak to its right, none to its left).
TEST(Video, StreakDroopsAFlatLineAsTheRcLaw) {
    Overrides ov = noiseFree();
    ov["width"] = "400";
    ov["height"] = "8";
    ov["video.scan"] = "frame";
    ov["mtf.enabled"] = "false";
    ov["agc"] = "off";
    const CameraParams plain = preset("pulnix-ag5745ef3", ov);
    ov["video.streak_fraction"] = "0.2";
    ov["video.streak_tau_px"] = "30";
    const CameraParams streak = preset("pulnix-ag5745ef3", ov);
    // A level well inside the 16-bit ADC, far above its rounding.
    const ImageF flat = test::uniform(400, 8, 1e13f);
    auto run = [&](const CameraParams& cam, const ImageF& in) {
        IiccdChain chain(cam, 1, test::configDir(), test::gammaTables());
        for (int k = 0; k < 3; ++k)
            chain.process(in.cview());
        std::vector<double> row(400);
        for (int x = 0; x < 400; ++x)
            row[static_cast<std::size_t>(x)] =
                static_cast<double>(chain.counts()(x, 4)) - cam.video_offset_dc;
        return row;
    };
    double scale = 1.0;
    {
        const std::vector<double> probe = run(plain, flat);
        scale = 1e13 * 20000.0 / probe[200];
    }
    const ImageF level = test::uniform(400, 8, static_cast<float>(scale));
    const std::vector<double> s0 = run(plain, level), s1 = run(streak, level);
    ASSERT_GT(s0[200], 10000.0);
    for (int x : {0, 1, 10, 30, 60, 150, 380}) {
        const double law = 1.0 - 0.2 * (1.0 - std::exp(-x / 30.0));
        EXPECT_NEAR(s1[static_cast<std::size_t>(x)] / s0[static_cast<std::size_t>(x)], law, 2e-4)
            << "x " << x;
    }
    ImageF bar = level;
    for (int y = 0; y < 8; ++y)
        for (int x = 200; x < 210; ++x)
            bar(x, y) = static_cast<float>(5.0 * scale);
    // With a bar the chain's own spreads (the tube's halo) make the line uneven: the droop
    // of the line the chain makes without it, as the direct sum of the exponential's weights
    // over the pixels before each one, within the ADC's rounding.
    const std::vector<double> b0 = run(plain, bar), b1 = run(streak, bar);
    const double r = std::exp(-1.0 / 30.0);
    for (int x : {190, 199, 205, 215, 260, 380}) {
        double m = 0.0;
        for (int j = 0; j < x; ++j)
            m += (1.0 - r) * std::pow(r, x - 1 - j) * b0[static_cast<std::size_t>(j)];
        EXPECT_NEAR(b1[static_cast<std::size_t>(x)], b0[static_cast<std::size_t>(x)] - 0.2 * m, 1.0)
            << "x " << x;
    }
    // What the droop takes off beyond the flat line's: nothing before the bar, most just after
    // it, less further on.
    auto extra = [&](int x) {
        const std::size_t i = static_cast<std::size_t>(x);
        return (b0[i] - b1[i]) - (s0[i] - s1[i]);
    };
    EXPECT_LT(std::fabs(extra(150)), 0.01 * (s0[150] - s1[150])) << "none well before it";
    EXPECT_GT(extra(211), 0.2 * (s0[211] - s1[211])) << "a dark streak after the bar";
    EXPECT_GT(extra(211), 3.0 * extra(260)) << "recovering";
    EXPECT_GT(extra(260), 0.0);
    EXPECT_THROW(test::calibrationTube({{"video.streak_fraction", "1"}}), SetupError);
    EXPECT_THROW(test::calibrationTube({{"video.streak_tau_px", "0"}}), SetupError);
}

TEST(BadInput, ClearErrors) {
    EXPECT_THROW(test::calibrationTube({{"mcp.bogus", "1"}}), SetupError);
    try {
        (void)parseCamera(test::configDir(), "width = 64\nheight = 48\nf_numbr = 2\n", "cam.toml");
        FAIL();
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("cam.toml:3"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("f_number"), std::string::npos) << e.what();
    }
    CameraParams cam = test::calibrationTube({{"width", "32"}, {"height", "16"}});
    IiccdChain chain(cam, 1, test::configDir(), test::gammaTables());
    ImageF wrong(31, 16);
    EXPECT_TRUE(chain.process(wrong.cview()).size_mismatch);
    ImageF bad = test::uniform(32, 16, 1.0f);
    bad(3, 4) = std::nanf("");
    bad(5, 6) = -1.0f;
    EXPECT_EQ(IiccdChain::countBadPixels(bad.cview()), 2);
    EXPECT_EQ(chain.process(bad.cview()).bad_input_px, 2);
    EXPECT_THROW(test::calibrationTube({{"agc", "sometimes"}}), SetupError);
}

// The blotchy fixed pattern (ccd.prnu_blotch_rel, prnu_blotch_sigma_px): white noise low-passed
// by a Gaussian of σ has the autocorrelation exp(−r²/4σ²) (the Gaussian convolved with itself);
// a uniform charge through the CCD with no read noise shows the pattern alone: its rms is the
// key's, its autocorrelation at lags 2-16 px follows that law within sampling error, and a
// cell-by-cell PRNU on top adds only at lag 0.
TEST(Ccd, BlotchyPatternHasTheGaussianLowPassAutocorrelation) {
    constexpr int w = 384, h = 288;
    const double sigma = 4.0, blotch = 0.05, white = 0.02;
    CameraParams cam = test::calibrationTube({{"width", std::to_string(w)},
                                              {"height", std::to_string(h)},
                                              {"ccd.read_noise_e", "0.0"},
                                              {"ccd.smear_rel", "0.0"},
                                              {"ccd.prnu_rel", std::to_string(white)},
                                              {"ccd.prnu_blotch_rel", std::to_string(blotch)},
                                              {"ccd.prnu_blotch_sigma_px", std::to_string(sigma)}});
    cam.full_well_e = 0.0;
    CcdStage ccd(cam, 7);
    ImageF img = test::uniform(w, h, 1000.0f);
    FieldContext ctx;
    ctx.period_s = 1.0 / 59.94;
    (void)ccd.apply(img.view(), ctx);
    std::vector<double> g(static_cast<std::size_t>(w) * h);
    double mean = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            mean += g[static_cast<std::size_t>(y) * w + x] =
                static_cast<double>(img(x, y)) / 1000.0 - 1.0;
    mean /= static_cast<double>(g.size());
    const auto cov = [&](int r) {
        double s = 0.0, n = 0.0;
        for (int y = 0; y < h; ++y)
            for (int x = 0; x + r < w; ++x) {
                s += (g[static_cast<std::size_t>(y) * w + x] - mean) *
                     (g[static_cast<std::size_t>(y) * w + x + r] - mean);
                n += 1.0;
            }
        return s / n;
    };
    // (1 + w)(1 + b) − 1 = w + b + wb: variance w² + b² + w²b².
    const double var0 = white * white + blotch * blotch + white * white * blotch * blotch;
    EXPECT_NEAR(cov(0), var0, 0.05 * var0);
    // Beyond lag 0 the cell pattern is uncorrelated; the blotches' correlation is the law's.
    // The sampling error of a lag covariance over a 384 × 288 frame of blotches of σ 4 px
    // (about 1700 independent blotches) is ~3 % of b².
    for (const int r : {2, 4, 6, 8, 12, 16}) {
        const double law = blotch * blotch * std::exp(-0.25 * r * r / (sigma * sigma));
        EXPECT_NEAR(cov(r), law, 0.08 * blotch * blotch) << "lag " << r;
    }
    // Without the blotch key the pattern is the cell's alone: no correlation at lag 2.
    CameraParams plain = cam;
    plain.prnu_blotch_rel = 0.0;
    CcdStage ccd2(plain, 7);
    ImageF img2 = test::uniform(w, h, 1000.0f);
    (void)ccd2.apply(img2.view(), ctx);
    double s = 0.0, n = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x + 2 < w; ++x) {
            s += (static_cast<double>(img2(x, y)) / 1000.0 - 1.0) *
                 (static_cast<double>(img2(x + 2, y)) / 1000.0 - 1.0);
            n += 1.0;
        }
    EXPECT_NEAR(s / n, 0.0, 0.05 * white * white);
}

}  // namespace
}  // namespace nvs::sensor
