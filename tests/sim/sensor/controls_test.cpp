// The camera's control policy (sim/sensor/chain.h, ControlSource::Command): a commanded manual
// gain reaches the MCP by eq. 6.1 each field, a commanded gate scales the signal and is held
// within [gate_min_s, field], and the AGC switch settles the video level at the preset's
// target; with ControlSource::Preset the commands are ignored.

#include <gtest/gtest.h>

#include <cmath>

#include "sim/sensor/chain.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace nvs::sensor {
namespace {

// Every noise and spatial effect off, frame scan: the output is a deterministic linear function
// of (Lpe + EBI)·gate·G(V) for a uniform scene.
CameraParams linearCamera() {
    return test::preset("pulnix-ag5745ef3", {{"width", "64"},
                                             {"height", "48"},
                                             {"photocathode.shot_noise", "false"},
                                             {"mcp.noise", "false"},
                                             {"phosphor.enabled", "false"},
                                             {"mtf.enabled", "false"},
                                             {"optics.cos4", "false"},
                                             {"ccd.read_noise_e", "0"},
                                             {"video.noise_dc", "0"},
                                             {"halo.enabled", "false"},
                                             {"mcp_saturation.enabled", "false"},
                                             {"ccd.full_well_e", "0"},
                                             {"video.scan", "frame"}});
}

double meanSignal(const IiccdChain& chain) {
    double s = 0.0;
    const ImageU16& v = chain.video();
    for (int y = 0; y < v.height(); ++y)
        for (int x = 0; x < v.width(); ++x)
            s += v.cview().row(y)[x];
    return s / (v.width() * v.height()) - chain.camera().video_offset_dc;
}

CameraCommand manual(double gain_V) {
    CameraCommand c;
    c.gain_V = gain_V;
    c.agc = false;
    return c;
}

// A uniform Lpe that puts the signal near `target_dc` above the offset at 6 V, manual.
ImageF uniformFor(const CameraParams& cam, double target_dc) {
    ImageF img(cam.width, cam.height);
    float lpe = 1e3f;
    for (int i = 0; i < 40; ++i) {
        img.fill(lpe);
        IiccdChain probe(cam, 1, test::configDir(), test::gammaTables(), {},
                         ControlSource::Command);
        (void)probe.process(img.cview(), manual(6.0), 0.0);
        const double s = meanSignal(probe);
        if (s > 10.0) {
            img.fill(static_cast<float>(static_cast<double>(lpe) * target_dc / s));
            return img;
        }
        lpe *= 4.0f;
    }
    return img;
}

TEST(CommandedControls, ManualGainReachesTheMcpEachFieldByEq6_1) {
    const CameraParams cam = linearCamera();
    const ImageF in = uniformFor(cam, 150.0);
    IiccdChain chain(cam, 1, test::configDir(), test::gammaTables(), {}, ControlSource::Command);
    // Eq. 6.1 under the supply's plate ceiling and the channel-gain ceiling: η·x/(1 + x/G_max).
    const auto G = [&](double v) {
        double vm = cam.mcp_offset_V + cam.mcp_V_per_control_V * v;
        if (cam.mcp_plate_max_V > 0.0) vm = std::min(vm, cam.mcp_plate_max_V);
        const double x = std::pow(vm / cam.mcp_crossover_V, cam.mcp_exponent);
        const double ch = cam.mcp_gain_max > 0.0 ? x / (1.0 + x / cam.mcp_gain_max) : x;
        return cam.mcp_detection_efficiency * ch;
    };
    const double volts[4] = {6.0, 5.5, 6.0, 5.0};
    double signal[4];
    for (int k = 0; k < 4; ++k) {
        const FieldInfo& info = chain.process(in.cview(), manual(volts[k]), k / 59.94);
        signal[k] = meanSignal(chain);
        EXPECT_EQ(info.gain_V, volts[k]);
        EXPECT_EQ(info.t_sample_s, k / 59.94);
    }
    EXPECT_GT(signal[0], 100.0);
    EXPECT_LT(signal[0], 200.0);
    EXPECT_EQ(signal[2], signal[0]);  // no state carried with phosphor and AGC off
    EXPECT_NEAR(signal[1], signal[0] * G(5.5) / G(6.0), 1.0);  // rounded counts: ±0.5 each
    EXPECT_NEAR(signal[3], signal[0] * G(5.0) / G(6.0), 1.0);
    // Above the loop's ceiling the command is held at agc_max_gain_V.
    EXPECT_EQ(chain.process(in.cview(), manual(99.0), 0.0).gain_V, cam.agc_max_gain_V);
}

TEST(CommandedControls, GateScalesTheSignalAndIsHeldWithinTheTubesRange) {
    const CameraParams cam = linearCamera();
    const ImageF in = uniformFor(cam, 160.0);
    IiccdChain chain(cam, 1, test::configDir(), test::gammaTables(), {}, ControlSource::Command);
    const double period_s = cam.integrationPeriod_s();
    CameraCommand cmd = manual(6.0);  // gate mode 0: continuous
    EXPECT_DOUBLE_EQ(chain.process(in.cview(), cmd, 0.0).gate_s, period_s);
    const double full = meanSignal(chain);
    cmd.gateMode = msg::GateMode::Gated;
    cmd.gate_s = period_s / 4.0;
    EXPECT_DOUBLE_EQ(chain.process(in.cview(), cmd, 0.0).gate_s, period_s / 4.0);
    EXPECT_NEAR(meanSignal(chain), full / 4.0, 0.6);
    cmd.gate_s = 1e-12;  // shorter than the tube's fastest gate
    EXPECT_DOUBLE_EQ(chain.process(in.cview(), cmd, 0.0).gate_s, cam.gate_min_s);
    cmd.gate_s = 0.0;  // gated, no width given: the preset's gate
    const double presetGate_s = cam.gate_s > 0.0 && cam.gate_s < period_s ? cam.gate_s : period_s;
    EXPECT_DOUBLE_EQ(chain.process(in.cview(), cmd, 0.0).gate_s, presetGate_s);
}

TEST(CommandedControls, AgcSwitchSettlesTheVideoLevelAtTheTarget) {
    CameraParams cam = linearCamera();
    cam.field_rate_Hz = 59.94;
    const ImageF in = uniformFor(cam, 40.0);  // dim at 6 V: the loop must raise the gain
    IiccdChain chain(cam, 1, test::configDir(), test::gammaTables(), {}, ControlSource::Command);
    CameraCommand cmd;
    cmd.agc = true;  // the preset's agc is "off": the switch runs the plain AGC loop
    const double firstGain = chain.process(in.cview(), cmd, 0.0).gain_V;
    for (int k = 1; k < 300; ++k)
        (void)chain.process(in.cview(), cmd, k / 59.94);
    EXPECT_NEAR(chain.lastInfo().level_dc, cam.agc_target_dc, 3.0);
    EXPECT_GT(chain.lastInfo().gain_V, firstGain);
}

// The loop starts from the configured state: at the first field the commanded gain, later the
// gain in effect when the switch is turned on (not the preset's 6 V).
TEST(CommandedControls, AgcStartsFromTheGainInEffect) {
    CameraParams cam = linearCamera();
    cam.field_rate_Hz = 59.94;
    const ImageF in = uniformFor(cam, 40.0);
    IiccdChain first(cam, 1, test::configDir(), test::gammaTables(), {}, ControlSource::Command);
    CameraCommand cmd = manual(4.5);
    cmd.agc = true;
    EXPECT_DOUBLE_EQ(first.process(in.cview(), cmd, 0.0).gain_V, 4.5);

    IiccdChain later(cam, 1, test::configDir(), test::gammaTables(), {}, ControlSource::Command);
    for (int k = 0; k < 5; ++k)
        EXPECT_DOUBLE_EQ(later.process(in.cview(), manual(3.0), k / 59.94).gain_V, 3.0);
    CameraCommand on = manual(7.0);  // the manual knob's setting no longer counts
    on.agc = true;
    EXPECT_DOUBLE_EQ(later.process(in.cview(), on, 5 / 59.94).gain_V, 3.0);
    // … and the loop then moves it (the scene is dim at 3 V: up).
    for (int k = 6; k < 40; ++k)
        (void)later.process(in.cview(), on, k / 59.94);
    EXPECT_GT(later.lastInfo().gain_V, 3.0);
}

TEST(CommandedControls, PresetSourceIgnoresCommands) {
    const CameraParams cam = linearCamera();
    const ImageF in = uniformFor(cam, 100.0);
    IiccdChain a(cam, 1, test::configDir(), test::gammaTables(), {}, ControlSource::Preset);
    IiccdChain b(cam, 1, test::configDir(), test::gammaTables());
    CameraCommand cmd = manual(3.0);
    cmd.gateMode = msg::GateMode::Gated;
    cmd.gate_s = 1e-4;
    for (int k = 0; k < 3; ++k) {
        const FieldInfo& ia = a.process(in.cview(), cmd, 0.0);
        const FieldInfo& ib = b.process(in.cview());
        EXPECT_EQ(ia.gain_V, cam.gain_V);
        EXPECT_EQ(ia.gate_s, ib.gate_s);
        EXPECT_EQ(ia.level_dc, ib.level_dc);
    }
}

}  // namespace
}  // namespace nvs::sensor
