// The IICCD camera model as the runtime's CameraStage:
//   - with the preset's controls it is sim/sensor's IiccdChain, bit for bit;
//   - the platform's gain_V reaches the MCP per field: signal ratio = the eq. 6.1 gain ratio
//     ((Voff + s·V)/Vc)^g written out here from the preset's numbers;
//   - the platform's gate scales the signal in proportion (photocathode on for gate_s);
//   - agc = true closes the loop on the video level (it settles at the target);
//   - expose() allocates nothing (global operator new counted: rt/bench/count_new.cpp);
//   - the scenario's [camera] table selects the preset, with strict keys.
#include "rt/camera_stage/camera_stage.h"

#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "rt/bench/alloc_count.h"
#include "rt/compose/scenario.h"
#include "sim/core/error.h"
#include "sim/sensor/chain.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::rt {
namespace {

using sensor::CameraParams;

GammaTableCache& gammaTables() {
    static GammaTableCache tables;
    return tables;
}

CameraParams preset(sensor::Overrides ov) {
    ov["width"] = "64";
    ov["height"] = "48";
    return sensor::loadCamera(test::configDir(), "pulnix-ag5745ef3", ov);
}

struct Frame {
    ImageF radiance;
    ImageU16 counts;
    FieldMeta applied;  // what the camera applied (expose's result)
    FrameRequest req;
    Frame(int w, int h, float L) : radiance(w, h), counts(w, h) { radiance.fill(L); }
};

TEST(IiccdCameraStage, PresetControlsAreTheChainBitForBit) {
    const CameraParams cam = preset({});  // shot noise, MCP noise, phosphor, MTF, field weave
    IiccdCameraStage stage(cam, "flat", 7, IiccdCameraStage::Controls::Preset, test::configDir(),
                           gammaTables());
    sensor::IiccdChain chain(cam, 7, test::configDir(), gammaTables());
    Frame f(64, 48, 0.0f);
    ImageF lpe(64, 48);
    for (int k = 0; k < 6; ++k) {
        for (int y = 0; y < 48; ++y) {
            for (int x = 0; x < 64; ++x) {
                const float L = 2e-7f * static_cast<float>(1 + (x / 8 + y / 8 + k) % 5);
                f.radiance.view().row(y)[x] = L;
                lpe.view().row(y)[x] = L * static_cast<float>(stage.lpePerRadiance());
            }
        }
        f.req.frame = k;
        stage.expose(f.req, RadianceFrame{{}, f.radiance.cview()}, f.counts.view(), f.applied);
        const sensor::FieldInfo& info = chain.process(lpe.cview());
        EXPECT_EQ(stage.lastField().level_dc, info.level_dc) << "field " << k;
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x)
                ASSERT_EQ(f.counts.cview().row(y)[x], chain.video().cview().row(y)[x])
                    << "field " << k << " (" << x << "," << y << ")";
    }
}

// The stage is an adapter: the platform's camera fields become the chain's command for the
// field (sim/sensor's control policy, tests/sim/sensor/controls_test.cpp), and what the chain
// applied comes back in the frame's metadata.
TEST(IiccdCameraStage, PlatformStateIsTheChainsCommand) {
    const CameraParams cam = preset({});
    IiccdCameraStage stage(cam, "flat", 5, IiccdCameraStage::Controls::Platform, test::configDir(),
                           gammaTables());
    sensor::IiccdChain chain(cam, 5, test::configDir(), gammaTables(), {},
                             sensor::ControlSource::Command);
    Frame f(64, 48, 3e-7f);
    ImageF lpe(64, 48);
    lpe.fill(3e-7f * static_cast<float>(stage.lpePerRadiance()));
    const double volts[3] = {5.0, 6.0, 4.5};
    for (int k = 0; k < 3; ++k) {
        f.req.frame = k;
        f.req.t_sample_s = k / 59.94;
        f.req.platform.agc = k == 2;
        f.req.platform.gain_V = volts[k];
        f.req.platform.gateMode = k == 1 ? msg::GateMode::Gated : msg::GateMode::Continuous;
        f.req.platform.gate_s = 2e-3;
        stage.expose(f.req, RadianceFrame{{}, f.radiance.cview()}, f.counts.view(), f.applied);
        const sensor::CameraCommand cmd{
            volts[k], 2e-3, k == 1 ? msg::GateMode::Gated : msg::GateMode::Continuous, k == 2};
        const sensor::FieldInfo& info = chain.process(lpe.cview(), cmd, f.req.t_sample_s);
        EXPECT_EQ(f.applied.gain_V, info.gain_V) << "field " << k;
        EXPECT_EQ(f.applied.gate_s, info.gate_s) << "field " << k;
        EXPECT_EQ(f.applied.t_sample_s, f.req.t_sample_s);
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x)
                ASSERT_EQ(f.counts.cview().row(y)[x], chain.video().cview().row(y)[x])
                    << "field " << k << " (" << x << "," << y << ")";
    }
}

TEST(IiccdCameraStage, ExposeAllocatesNothing) {
    if (!bench::allocationCounting())
        GTEST_SKIP() << "operator new is not replaced in this build (AddressSanitizer)";
    const CameraParams cam = preset({{"agc", "agc"}});
    IiccdCameraStage stage(cam, "moon", 3, IiccdCameraStage::Controls::Platform, test::configDir(),
                           gammaTables());
    Frame f(64, 48, 3e-7f);
    stage.expose(f.req, RadianceFrame{{}, f.radiance.cview()}, f.counts.view(), f.applied);
    const std::uint64_t before = bench::allocationCount();
    for (int k = 0; k < 10; ++k) {
        f.req.platform.agc = k % 3 != 0;
        f.req.platform.gain_V = 4.0 + 0.1 * k;
        f.req.platform.gateMode = k % 2 == 1 ? msg::GateMode::Gated : msg::GateMode::Continuous;
        f.req.platform.gate_s = 1e-3;
        stage.expose(f.req, RadianceFrame{{}, f.radiance.cview()}, f.counts.view(), f.applied);
    }
    EXPECT_EQ(bench::allocationCount() - before, 0u);
}

TEST(ScenarioCamera, PresetSetsSizeDepthAndRateUnlessGiven) {
    const Scenario a = parseScenario(
        "[scenario]\nname = \"a\"\n[camera]\npreset = \"pulnix-ag5745ef3\"\n"
        "[[source]]\nkind = \"test_pattern\"\n",
        "a.toml", test::configDir());
    ASSERT_TRUE(a.camera.enabled);
    EXPECT_EQ(a.width, 768);
    EXPECT_EQ(a.height, 494);
    EXPECT_EQ(a.bits, a.camera.params.adc_bits);
    // A field-scan camera runs interlaced: 29.97 frames/s (30000/1001) of 59.94 fields/s.
    EXPECT_EQ(a.scan, ScanKind::Interlaced);
    EXPECT_EQ(a.rate.num, 30000);
    EXPECT_EQ(a.rate.den, 1001);
    EXPECT_NEAR(a.camera.params.field_rate_Hz, 60000.0 / 1001.0, 1e-9);
    const Scenario b = parseScenario(
        "[scenario]\nname = \"b\"\nwidth = 96\nheight = 64\nframe_rate_hz = 30\n"
        "[platform]\nagc = false\ngate_mode = 1\ngate_s = 0.001\n"
        "[camera]\npreset = \"pulnix-ag5745ef3\"\nset = [\"video.scan=frame\"]\n"
        "spectrum = \"blackbody:2856\"\nseed = 5\ncontrols = \"preset\"\n"
        "[[source]]\nkind = \"test_pattern\"\n",
        "b.toml", test::configDir());
    EXPECT_EQ(b.camera.params.width, 96);
    EXPECT_EQ(b.camera.params.height, 64);
    EXPECT_DOUBLE_EQ(b.camera.params.field_rate_Hz, 60.0);  // frame scan: two fields a frame
    EXPECT_EQ(b.camera.seed, 5u);
    EXPECT_FALSE(b.camera.controlsFromPlatform);
    EXPECT_FALSE(b.platform.agc);
    EXPECT_EQ(b.platform.gateMode, msg::GateMode::Gated);
}

TEST(ScenarioCamera, BadCameraTablesNameTheFileAndLine) {
    const auto expectError = [](const std::string& text, const std::string& needle) {
        try {
            parseScenario(text, "bad.toml", test::configDir());
            ADD_FAILURE() << "no error for: " << text;
        } catch (const SetupError& e) {
            EXPECT_NE(std::string(e.what()).find(needle), std::string::npos) << e.what();
        }
    };
    const std::string head = "[scenario]\nname = \"x\"\n[[source]]\nkind = \"test_pattern\"\n";
    expectError(head + "[camera]\npreset = \"no-such-camera\"\n", "bad.toml:6");
    expectError(head + "[camera]\npreset = \"pulnix-ag5745ef3\"\ncolour = true\n", "colour");
    expectError(head + "[camera]\npreset = \"pulnix-ag5745ef3\"\nspectrum = \"laser\"\n",
                "bad.toml:7");
    expectError(head + "[camera]\npreset = \"pulnix-ag5745ef3\"\nset = [\"mcp.nope=1\"]\n",
                "mcp.nope");
    expectError(head + "[platform]\ngate_mode = 3\n", "gate_mode");
}

}  // namespace
}  // namespace nvs::rt
