// Bad presets stop with file:line (docs/style.md §8): out-of-range values, an unknown AGC mode,
// an unknown key; a bad --set names the override. And the shipped presets load.

#include <gtest/gtest.h>

#include <string>

#include "sim/bolometer/camera.h"
#include "sim/core/error.h"
#include "tests/sim/bolometer/bolometer_test_util.h"

namespace nvs::bolometer {
namespace {

std::string errorOf(const std::string& text, const Overrides& ov = {}) {
    try {
        parseThermalCamera(text, "bad.toml", ov);
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

TEST(ThermalPreset, OutOfRangeValuesNameFileAndLine) {
    EXPECT_NE(errorOf("name = \"x\"\n[noise]\nnetd_K = -0.05\n").find("bad.toml:3"),
              std::string::npos);
    EXPECT_NE(errorOf("[detector]\ntime_constant_s = 0.0\n").find("bad.toml:2"), std::string::npos);
    EXPECT_NE(errorOf("[detector]\n\ntime_constant_s = -1.0\n").find("bad.toml:3"),
              std::string::npos);
    const std::string agc = errorOf("[agc]\nmode = \"gamma\"\n");
    EXPECT_NE(agc.find("bad.toml:2"), std::string::npos) << agc;
    EXPECT_NE(agc.find("unknown AGC mode"), std::string::npos) << agc;
    EXPECT_NE(errorOf("[optics]\ntransmission = 1.5\n").find("bad.toml:2"), std::string::npos);
    EXPECT_NE(errorOf("[noise]\nrow_rel = 0.8\ncolumn_rel = 0.8\n").find("bad.toml:3"),
              std::string::npos);
    EXPECT_NE(errorOf("[shutter]\nclosed_frames = 2\nsettle_frames = 2\n").find("bad.toml:3"),
              std::string::npos);
    EXPECT_NE(errorOf("[noise]\nnetd_mK = 40\n").find("bad.toml:2"), std::string::npos);
    // 8 closed frames at 30 Hz take 0.27 s: an FFC every 0.2 s would never end.
    EXPECT_NE(errorOf("frame_rate_Hz = 30.0\n[shutter]\ninterval_s = 0.2\n").find("bad.toml:3"),
              std::string::npos);
}

TEST(ThermalPreset, BadOverridesNameTheKey) {
    EXPECT_NE(errorOf("", {{"noise.netd_K", "-1"}}).find("--set noise.netd_K"), std::string::npos);
    EXPECT_NE(errorOf("", {{"agc.mode", "log"}}).find("--set agc.mode"), std::string::npos);
    EXPECT_NE(errorOf("", {{"noise.netdK", "1"}}).find("no such"), std::string::npos);
}

TEST(ThermalPreset, ShippedPresetsLoadWithTheirDatasheetFigures) {
    const ThermalCameraParams a = test::thermalPreset("boson-640");
    EXPECT_EQ(a.width, 640);
    EXPECT_EQ(a.height, 512);
    EXPECT_DOUBLE_EQ(a.pitch_um, 12.0);
    EXPECT_DOUBLE_EQ(a.netd_K, 0.040);
    EXPECT_EQ(a.adc_bits, 14);
    const ThermalCameraParams b = test::thermalPreset("boson-320");
    EXPECT_EQ(b.width, 320);
    EXPECT_EQ(b.height, 256);
    EXPECT_THROW(test::thermalPreset("no-such-core"), SetupError);
}

}  // namespace
}  // namespace nvs::bolometer
