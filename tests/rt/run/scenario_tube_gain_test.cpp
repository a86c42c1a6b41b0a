// The tube's luminous gain at every control voltage a shipped scenario commands, against the
// published ranges (issue 29; docs/validation.md, "Tube gain"). Ranges, as published:
// - Gen III tubes' luminous gain at full gain: 2e4–8e4 fL/fc (issue 29's survey of Gen III
//   data sheets; MX-10160-class tubes are measured by the method of the nv-intl.com "Gain"
//   page, which also gives 1 fL/fc = 1/π cd m⁻² lx⁻¹).
// - An intensified camera's gain control: 2512–70795 (DVC-1412 Intensicam manual, Figure 9.5-1,
//   "Luminous Gain versus IGN Argument", log-linear over the control's range;
//   https://www.easymanua.ls/dvc/dvc-1412/manual?p=57).
// The ranges are not bent to fit; the preset's supply ceiling (plate_max_V) is placed between
// what Table 18-6 and this range allow (docs/validation.md, "Tube gain").
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <set>
#include <string>

#include "rt/compose/scenario.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::rt {
namespace {
namespace fs = std::filesystem;

constexpr double kGen3MaxGainLow_fL_fc = 2.0e4;
constexpr double kGen3MaxGainHigh_fL_fc = 8.0e4;
constexpr double kCameraRangeLow_fL_fc = 2512.0;
constexpr double kCameraRangeHigh_fL_fc = 70795.0;

// The shipped scenario files: each folder's scenario.toml and the RIT render scenarios.
std::vector<fs::path> shippedScenarios() {
    std::vector<fs::path> out;
    const fs::path root = fs::path(NVS_SOURCE_DIR) / "scenarios";
    for (const auto& e : fs::directory_iterator(root)) {
        if (fs::exists(e.path() / "scenario.toml")) out.push_back(e.path() / "scenario.toml");
    }
    for (const auto& e : fs::directory_iterator(root / "rit")) {
        const std::string name = e.path().filename().string();
        if (e.path().extension() == ".toml" && name.rfind("scene", 0) != 0) out.push_back(e.path());
    }
    return out;
}

// Every control voltage a scenario commands in manual gain: its [platform] gain_V (with AGC
// off), each event's gain_V; with the AGC on, the top of the AGC's range.
std::set<double> commandedVoltages(const Scenario& sc) {
    std::set<double> v;
    const sensor::CameraParams& cam = sc.camera.params;
    if (!sc.camera.controlsFromPlatform) {
        v.insert(cam.agc == sensor::AgcMode::Off ? cam.gain_V : cam.agc_max_gain_V);
    } else {
        v.insert(sc.platform.agc ? cam.agc_max_gain_V : sc.platform.gain_V);
    }
    for (const TimelineEvent& e : sc.events) {
        if (e.gain_V) v.insert(*e.gain_V);
    }
    return v;
}

TEST(ScenarioTubeGain, EveryShippedScenarioVoltageAgainstThePublishedRanges) {
    int scenarios = 0;
    for (const fs::path& file : shippedScenarios()) {
        const Scenario sc = loadScenario(file, test::configDir());
        if (!sc.camera.enabled || sc.camera.thermal) continue;  // no tube
        ++scenarios;
        const sensor::CameraParams& cam = sc.camera.params;
        // The tube at its full control voltage: a Gen III tube's maximum gain.
        const double top = cam.luminousGain_fL_fc(9.0);
        EXPECT_GE(top, kGen3MaxGainLow_fL_fc) << file;
        EXPECT_LE(top, kGen3MaxGainHigh_fL_fc) << file;
        for (const double v : commandedVoltages(sc)) {
            const double g = cam.luminousGain_fL_fc(v);
            std::printf("%-40s %4.2f V: %.4g fL/fc\n",
                        fs::relative(file, fs::path(NVS_SOURCE_DIR)).string().c_str(), v, g);
            EXPECT_LE(g, kCameraRangeHigh_fL_fc) << file << " at " << v << " V";
            EXPECT_LE(g, kGen3MaxGainHigh_fL_fc) << file << " at " << v << " V";
            EXPECT_GE(g, kCameraRangeLow_fL_fc) << file << " at " << v << " V";
        }
    }
    EXPECT_GE(scenarios, 15);
}

}  // namespace
}  // namespace nvs::rt
