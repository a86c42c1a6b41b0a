// GCC cannot see that the replaced operators below pair malloc with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
// The IICCD camera model as the runtime's CameraStage:
//   - with the preset's controls it is sim/sensor's IiccdChain, bit for bit;
//   - the platform's gain_V reaches the MCP per field: signal ratio = the eq. 6.1 gain ratio
//     ((Voff + s·V)/Vc)^g written out here from the preset's numbers;
//   - the platform's gate scales the signal in proportion (photocathode on for gate_s);
//   - agc = true closes the loop on the video level (it settles at the target);
//   - expose() allocates nothing (global operator new counted in this binary);
//   - the scenario's [camera] table selects the preset, with strict keys.
#include "rt/camera_stage/camera_stage.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdlib>
#include <new>
#include <string>

#include "rt/run/scenario.h"
#include "sim/core/error.h"
#include "sim/sensor/chain.h"
#include "tests/sim/core/test_paths.h"

namespace {
std::atomic<long> gAllocations{0};
}  // namespace

void* operator new(std::size_t n) {
    gAllocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
    return operator new(n);
}
void* operator new(std::size_t n, std::align_val_t a) {
    gAllocations.fetch_add(1, std::memory_order_relaxed);
    const std::size_t al = static_cast<std::size_t>(a);
    if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) {
    return operator new(n, a);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
    std::free(p);
}

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

// A camera with every noise and spatial effect off, frame scan: the output is a deterministic
// linear function of (L + EBI)·gate·G(V) for a uniform scene.
CameraParams linearPreset() {
    return preset({{"photocathode.shot_noise", "false"},
                   {"mcp.noise", "false"},
                   {"phosphor.enabled", "false"},
                   {"mtf.enabled", "false"},
                   {"optics.cos4", "false"},
                   {"ccd.read_noise_e", "0"},
                   {"ccd.full_well_e", "0"},
                   {"video.scan", "frame"}});
}

struct Frame {
    ImageF radiance;
    ImageU16 counts;
    FrameMeta meta;
    FrameRequest req;
    Frame(int w, int h, float L) : radiance(w, h), counts(w, h) { radiance.fill(L); }
};

double mean(const ImageU16& img) {
    double s = 0.0;
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x)
            s += img.cview().row(y)[x];
    return s / (img.width() * img.height());
}

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
        stage.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
        const sensor::FieldInfo& info = chain.process(lpe.cview());
        EXPECT_EQ(stage.lastField().level_dc, info.level_dc) << "field " << k;
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x)
                ASSERT_EQ(f.counts.cview().row(y)[x], chain.video().cview().row(y)[x])
                    << "field " << k << " (" << x << "," << y << ")";
    }
}

// Finds a uniform radiance that puts the signal near `target_dc` above the offset at gain_V = 6.
float radianceFor(const CameraParams& cam, double target_dc) {
    float L = 1e-12f;
    for (int i = 0; i < 40; ++i) {
        IiccdCameraStage probe(cam, "flat", 1, IiccdCameraStage::Controls::Platform,
                               test::configDir(), gammaTables());
        Frame f(64, 48, L);
        f.req.platform.agc = false;
        f.req.platform.gain_V = 6.0;
        probe.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
        const double s = mean(f.counts) - cam.video_offset_dc;
        if (s > 10.0) return static_cast<float>(static_cast<double>(L) * target_dc / s);
        L *= 4.0f;
    }
    return L;
}

TEST(IiccdCameraStage, PlatformGainReachesTheMcpEachField) {
    const CameraParams cam = linearPreset();
    const float L = radianceFor(cam, 150.0);
    IiccdCameraStage stage(cam, "flat", 1, IiccdCameraStage::Controls::Platform, test::configDir(),
                           gammaTables());
    // Eq. 6.1 with this preset's numbers: G(V) = ((Voff + s·V)/Vc)^g.
    const auto G = [&](double v) {
        return std::pow((cam.mcp_offset_V + cam.mcp_V_per_control_V * v) / cam.mcp_crossover_V,
                        cam.mcp_exponent);
    };
    const double volts[4] = {6.0, 5.5, 6.0, 5.0};
    double signal[4];
    Frame f(64, 48, L);
    for (int k = 0; k < 4; ++k) {
        f.req.frame = k;
        f.req.t_sample_s = k / 59.94;
        f.req.platform.agc = false;
        f.req.platform.gain_V = volts[k];
        stage.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
        signal[k] = mean(f.counts) - cam.video_offset_dc;
        EXPECT_EQ(f.meta.platform.gain_V, volts[k]);
        EXPECT_EQ(f.meta.platform.t_sample_s, f.req.t_sample_s);
    }
    EXPECT_GT(signal[0], 100.0);  // well inside the ADC range (EBI makes it not exactly 150)
    EXPECT_LT(signal[0], 200.0);
    EXPECT_EQ(signal[2], signal[0]);  // no state carried with phosphor and AGC off
    // Rounded counts: ±0.5 DC on each signal.
    EXPECT_NEAR(signal[1], signal[0] * G(5.5) / G(6.0), 1.0);
    EXPECT_NEAR(signal[3], signal[0] * G(5.0) / G(6.0), 1.0);
    EXPECT_LT(signal[3], 0.3 * signal[0]);  // the exponent g = 10 makes gain steep
}

TEST(IiccdCameraStage, PlatformGateScalesTheSignal) {
    const CameraParams cam = linearPreset();
    const float L = radianceFor(cam, 160.0);
    IiccdCameraStage stage(cam, "flat", 1, IiccdCameraStage::Controls::Platform, test::configDir(),
                           gammaTables());
    const double period_s = cam.integrationPeriod_s();
    Frame f(64, 48, L);
    f.req.platform.agc = false;
    f.req.platform.gain_V = 6.0;
    f.req.platform.gateMode = 0;  // continuous
    stage.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
    const double full = mean(f.counts) - cam.video_offset_dc;
    EXPECT_DOUBLE_EQ(f.meta.platform.gate_s, period_s);
    f.req.platform.gateMode = 1;  // gated for a quarter of the frame
    f.req.platform.gate_s = period_s / 4.0;
    stage.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
    const double quarter = mean(f.counts) - cam.video_offset_dc;
    EXPECT_DOUBLE_EQ(f.meta.platform.gate_s, period_s / 4.0);
    EXPECT_NEAR(quarter, full / 4.0, 0.6);
    // A gate shorter than the tube's fastest is held at gate_min_s.
    f.req.platform.gate_s = 1e-12;
    stage.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
    EXPECT_DOUBLE_EQ(f.meta.platform.gate_s, cam.gate_min_s);
}

TEST(IiccdCameraStage, AgcOnSettlesTheVideoLevelAtTheTarget) {
    CameraParams cam = linearPreset();
    cam.field_rate_Hz = 59.94;
    const float L = radianceFor(cam, 40.0);  // dim at 6 V: the loop must raise the gain
    IiccdCameraStage stage(cam, "flat", 1, IiccdCameraStage::Controls::Platform, test::configDir(),
                           gammaTables());
    Frame f(64, 48, L);
    f.req.platform.agc = true;  // the camera's AGC switch on (preset agc = "off" → AGC loop)
    double firstGain = 0.0;
    for (int k = 0; k < 300; ++k) {
        stage.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
        if (k == 0) firstGain = f.meta.platform.gain_V;
    }
    EXPECT_NEAR(stage.lastField().level_dc, cam.agc_target_dc, 3.0);
    EXPECT_GT(f.meta.platform.gain_V, firstGain);
}

TEST(IiccdCameraStage, ExposeAllocatesNothing) {
    const CameraParams cam = preset({{"agc", "agc"}});
    IiccdCameraStage stage(cam, "moon", 3, IiccdCameraStage::Controls::Platform, test::configDir(),
                           gammaTables());
    Frame f(64, 48, 3e-7f);
    stage.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
    const long before = gAllocations.load();
    for (int k = 0; k < 10; ++k) {
        f.req.platform.agc = k % 3 != 0;
        f.req.platform.gain_V = 4.0 + 0.1 * k;
        f.req.platform.gateMode = k % 2;
        f.req.platform.gate_s = 1e-3;
        stage.expose(f.req, f.radiance.cview(), f.counts.view(), f.meta);
    }
    EXPECT_EQ(gAllocations.load() - before, 0);
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
    EXPECT_EQ(a.rate.num, 60000);  // 59.94 fields/s, exactly 60000/1001
    EXPECT_EQ(a.rate.den, 1001);
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
    EXPECT_EQ(b.platform.gateMode, 1);
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
