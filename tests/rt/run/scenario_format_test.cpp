// The scenario format (the one loader, rt/compose/scenario.h): every shipped scenario and the
// RIT render scenarios load; bad input — unknown keys in any table, a missing telemetry log, a
// timeline event after the end, an unknown lamp — is a clear error naming file:line.
#include <gtest/gtest.h>

#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <optional>

#include "rt/compose/scenario.h"
#include "rt/run/run.h"
#include "sim/core/error.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::rt {
namespace {
namespace fs = std::filesystem;

const fs::path kRit = fs::path(NVS_SOURCE_DIR) / "scenarios" / "rit" / "scene.toml";

fs::path writeScenario(const char* name, const std::string& body) {
    const fs::path d = fs::temp_directory_path() / name;
    fs::remove_all(d);
    fs::create_directories(d);
    std::ofstream(d / "scenario.toml") << body;
    return d;
}

std::string rendered(const std::string& extra) {
    return "[scenario]\nname = \"t\"\nduration_s = 1.0\nframe_rate_hz = 10\nwidth = 96\nheight = "
           "64\n"
           "[site]\nlat_deg = 43.16856\nlon_deg = -77.61583\nheight_m = 218.0\n"
           "[camera]\npreset = \"pulnix-ag5745ef3\"\n[scene]\nfile = \"" +
           kRit.string() + "\"\n" + extra;
}

std::string errorOf(const fs::path& dir) {
    try {
        loadScenario(dir, test::configDir());
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

TEST(ScenarioFormat, ShippedScenariosLoad) {
    int n = 0;
    for (const auto& e : fs::directory_iterator(fs::path(NVS_SOURCE_DIR) / "scenarios")) {
        if (!fs::exists(e.path() / "scenario.toml")) continue;
        const Scenario sc = loadScenario(e.path(), test::configDir());
        EXPECT_TRUE(sc.rendered) << e.path();
        EXPECT_FALSE(sc.group.empty()) << e.path();
        EXPECT_TRUE(sc.duration_s.has_value()) << e.path();
        EXPECT_TRUE(fs::exists(sc.scene.sceneFile)) << e.path();
        ++n;
    }
    EXPECT_GE(n, 9);
}

TEST(ScenarioFormat, RitRenderScenariosLoadWithTheirSiteAndPreset) {
    for (const char* name : {"nolight", "tghg", "stlamp", "full_moon"}) {
        const Scenario sc =
            loadScenario(kRit.parent_path() / (std::string(name) + ".toml"), test::configDir());
        EXPECT_TRUE(sc.rendered);
        EXPECT_NEAR(sc.scene.site.lat_deg, 43.16856, 1e-9);
        EXPECT_NEAR(sc.scene.site.lon_deg, -77.61583, 1e-9);
        EXPECT_EQ(sc.camera.preset, "pulnix-ag5745ef3");
        EXPECT_EQ(sc.width, 768);
        EXPECT_EQ(sc.height, 494);
        EXPECT_TRUE(fs::exists(sc.scene.sceneFile));
    }
}

// One strict check for every table: a misspelt key names its place and the key meant.
TEST(ScenarioFormat, EveryTableSuggestsTheKeyMeant) {
    const struct {
        const char* right;  // a line of the valid scenario, and its misspelling
        const char* wrong;
        const char* key;
        const char* meant;
    } cases[] = {
        {"frame_rate_hz = 10", "frame_rate_hx = 10", "scenario.frame_rate_hx", "frame_rate_hz"},
        {"lat_deg = 43.16856", "lat_degs = 43.16856", "site.lat_degs", "lat_deg"},
        {"[camera]\n", "[camera]\nspectra = \"flat\"\n", "camera.spectra", "spectrum"},
        {"[scene]\n", "[scene]\nlamp_on = []\n", "scene.lamp_on", "lamps_on"},
        {"[atmosphere]\n", "[atmosphere]\nvisibility = 10\n", "atmosphere.visibility",
         "visibility_km"},
        {"[runtime]\n", "[runtime]\nrender_thread = 2\n", "runtime.render_thread",
         "render_threads"},
        {"[platform]\n", "[platform]\ngain_v = 4.0\n", "platform.gain_v", "gain_V"},
    };
    for (const auto& c : cases) {
        std::string body = rendered("[atmosphere]\n[runtime]\n[platform]\n");
        const auto at = body.find(c.right);
        ASSERT_NE(at, std::string::npos) << c.right;
        body.replace(at, std::string(c.right).size(), c.wrong);
        const std::string msg = errorOf(writeScenario("nvs_sf_hint", body));
        EXPECT_NE(msg.find("unknown key '" + std::string(c.key) + "'"), std::string::npos) << msg;
        EXPECT_NE(msg.find("did you mean '" + std::string(c.meant) + "'"), std::string::npos)
            << msg;
    }
}

TEST(ScenarioFormat, UnknownKeyNamesFileAndLine) {
    const fs::path d = writeScenario("nvs_sf_key", rendered("[platform]\ngian_V = 4.0\n"));
    const std::string msg = errorOf(d);
    EXPECT_NE(msg.find("scenario.toml:16:1: unknown key 'platform.gian_V'"), std::string::npos)
        << msg;
    EXPECT_NE(msg.find("did you mean 'gain_V'"), std::string::npos) << msg;
}

TEST(ScenarioFormat, MissingTelemetryLogNamesFileAndLine) {
    const fs::path d =
        writeScenario("nvs_sf_log", rendered("[telemetry]\nsource = \"replay:no-such.candump\"\n"));
    const std::string msg = errorOf(d);
    EXPECT_NE(msg.find("scenario.toml:16:10: key 'telemetry.source': telemetry log not found"),
              std::string::npos)
        << msg;
}

TEST(ScenarioFormat, EventAfterTheEndNamesFileAndLine) {
    const fs::path d =
        writeScenario("nvs_sf_event", rendered("[[event]]\nt_s = 2.5\ngain_V = 5.0\n"));
    const std::string msg = errorOf(d);
    EXPECT_NE(msg.find("scenario.toml:16:7: key 'event[0].t_s': the event at 2.5"),
              std::string::npos)
        << msg;
    EXPECT_NE(msg.find("after the end of the scenario"), std::string::npos) << msg;
}

TEST(ScenarioFormat, EventThatChangesNothingOrOnWithoutLamp) {
    EXPECT_NE(errorOf(writeScenario("nvs_sf_empty", rendered("[[event]]\nt_s = 0.5\n")))
                  .find("changes nothing"),
              std::string::npos);
    EXPECT_NE(errorOf(writeScenario("nvs_sf_on", rendered("[[event]]\nt_s = 0.5\non = true\n")))
                  .find("needs lamp = NAME"),
              std::string::npos);
}

TEST(ScenarioFormat, SourceAndSceneExcludeEachOther) {
    const fs::path d =
        writeScenario("nvs_sf_src", rendered("[[source]]\nkind = \"test_pattern\"\n"));
    EXPECT_NE(errorOf(d).find("[[source]] and [scene] exclude each other"), std::string::npos);
}

TEST(ScenarioFormat, UnknownLampInAnEventFailsAtRunSetup) {
    const fs::path d = writeScenario(
        "nvs_sf_lamp", rendered("[[event]]\nt_s = 0.5\nlamp = \"moon_lamp\"\non = true\n"));
    RunRequest req;
    req.scenario = d.string();
    req.dirs = test::dataDirs();
    req.clock = ClockKind::Sim;
    try {
        runScenario(req, stderr);
        FAIL();
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("scenario.toml:16:7: unknown lamp 'moon_lamp'"),
                  std::string::npos)
            << e.what();
    }
}

std::string pattern(const std::string& scenarioExtra, const std::string& tables) {
    return "[scenario]\nname = \"p\"\n" + scenarioExtra + "[[source]]\nkind = \"test_pattern\"\n" +
           tables;
}

// Pacing modes: scan = progressive | interlaced; the rate given is the output frame rate, and a
// camera preset is driven once per field (twice the frame rate) when interlaced.
TEST(ScenarioFormat, ScanSelectsThePacingMode) {
    Scenario sc = parseScenario(pattern("", ""), "p.toml", test::configDir());
    EXPECT_EQ(sc.scan, ScanKind::Progressive);
    EXPECT_EQ(sc.rate.num, 60);
    sc = parseScenario(pattern("scan = \"interlaced\"\n", ""), "p.toml", test::configDir());
    EXPECT_EQ(sc.scan, ScanKind::Interlaced);
    EXPECT_EQ(sc.rate.num, 30);  // 30 Hz frames of 60 Hz fields without a camera
    // The field-scan NTSC preset: 29.97 Hz frames, the camera at 59.94 fields/s.
    sc = parseScenario(pattern("scan = \"interlaced\"\nwidth = 64\nheight = 48\n",
                               "[camera]\npreset = \"pulnix-ag5745ef3\"\n"),
                       "p.toml", test::configDir());
    EXPECT_EQ(sc.rate.num, 30000);
    EXPECT_EQ(sc.rate.den, 1001);
    EXPECT_NEAR(sc.camera.params.field_rate_Hz, 60000.0 / 1001.0, 1e-9);
    // Without `scan` the field-scan preset runs interlaced, as it delivers its fields.
    sc = parseScenario(
        pattern("width = 64\nheight = 48\n", "[camera]\npreset = \"pulnix-ag5745ef3\"\n"), "p.toml",
        test::configDir());
    EXPECT_EQ(sc.scan, ScanKind::Interlaced);
    EXPECT_EQ(sc.rate.num, 30000);
    EXPECT_NEAR(sc.camera.params.field_rate_Hz, 60000.0 / 1001.0, 1e-9);
    // Progressive with the same preset is the field-rate loop (one field per frame) at the
    // field rate, and only there.
    sc = parseScenario(pattern("scan = \"progressive\"\nwidth = 64\nheight = 48\n",
                               "[camera]\npreset = \"pulnix-ag5745ef3\"\n"),
                       "p.toml", test::configDir());
    EXPECT_EQ(sc.scan, ScanKind::Progressive);
    EXPECT_EQ(sc.rate.num, 60000);
    EXPECT_NEAR(sc.camera.params.field_rate_Hz, 60000.0 / 1001.0, 1e-9);
    EXPECT_THROW(parseScenario(pattern("scan = \"progressive\"\nframe_rate_hz = 29.97\n",
                                       "[camera]\npreset = \"pulnix-ag5745ef3\"\n"),
                               "p.toml", test::configDir()),
                 SetupError);
}

TEST(ScenarioFormat, BadScanAndTriggerNameFileAndLine) {
    const auto err = [](const std::string& text) {
        try {
            parseScenario(text, "s.toml", test::configDir());
        } catch (const SetupError& e) {
            return std::string(e.what());
        }
        return std::string();
    };
    std::string msg = err(pattern("scan = \"sideways\"\n", ""));
    EXPECT_NE(msg.find("s.toml:3"), std::string::npos) << msg;
    msg = err(pattern("scan = \"interlaced\"\nwidth = 64\nheight = 48\n",
                      "[camera]\npreset = \"thesis-eq7.1\"\n"));
    EXPECT_NE(msg.find("field-scan"), std::string::npos) << msg;
    EXPECT_NE(msg.find("s.toml:3"), std::string::npos) << msg;
    msg = err(pattern("", "[runtime]\ntrigger = \"gpio:gpiochip0\"\n"));
    EXPECT_NE(msg.find("s.toml:6"), std::string::npos) << msg;
    msg = err(pattern("", "[runtime]\ntrigger = \"can:vcan0\"\n"));
    EXPECT_NE(msg.find("gpio:CHIP:LINE"), std::string::npos) << msg;
    const Scenario sc = parseScenario(pattern("", "[runtime]\ntrigger = \"gpio:gpiochip0:18\"\n"),
                                      "s.toml", test::configDir());
    ASSERT_TRUE(sc.trigger.has_value());
    EXPECT_EQ(*sc.trigger, "gpio:gpiochip0:18");
}

// [runtime] camera_threads: 1..16, and the camera chain's rows split over a pool give the same
// video as one thread (the run's overrides, nvstim run --camera-threads and --render-threads,
// take the same path); out-of-range values name file and line or the option.
TEST(ScenarioFormat, CameraThreadsSplitTheChainWithTheSameBits) {
    const std::string tables = "[camera]\npreset = \"pulnix-ag5745ef3\"\n";
    const std::string size = "width = 96\nheight = 64\nseed = 5\n";
    EXPECT_EQ(parseScenario(pattern(size, tables), "p.toml", test::configDir()).cameraThreads, 1);
    for (const char* bad : {"0", "17"}) {
        try {
            parseScenario(pattern(size, tables + "[runtime]\ncamera_threads = " + bad + "\n"),
                          "p.toml", test::configDir());
            FAIL() << bad;
        } catch (const SetupError& e) {
            EXPECT_NE(std::string(e.what()).find("p.toml:"), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("camera_threads"), std::string::npos) << e.what();
        }
    }
    const std::filesystem::path d = std::filesystem::path(testing::TempDir()) / "nvs_camthreads";
    std::filesystem::create_directories(d);
    std::ofstream(d / "scenario.toml") << pattern(size, tables);
    const auto run = [&](std::optional<int> cameraThreads, std::optional<int> renderThreads) {
        RunRequest req;
        req.scenario = (d / "scenario.toml").string();
        req.dirs = test::dataDirs();
        req.clock = ClockKind::Sim;
        req.frames = 4;
        req.cameraThreads = cameraThreads;
        req.renderThreads = renderThreads;
        const std::filesystem::path out =
            d / ("out" + std::to_string(cameraThreads.value_or(1)) + ".y4m");
        req.outputs = {"y4m:" + out.string()};
        std::FILE* quiet = std::fopen("/dev/null", "w");
        EXPECT_EQ(runScenario(req, quiet), 0);
        std::fclose(quiet);
        std::ifstream in(out, std::ios::binary);
        return std::string(std::istreambuf_iterator<char>(in), {});
    };
    const std::string one = run(std::nullopt, std::nullopt), three = run(3, 1);
    EXPECT_GT(one.size(), 4u * 96 * 64);
    EXPECT_TRUE(one == three) << "camera_threads = 3 changed the video";
    RunRequest req;
    req.scenario = (d / "scenario.toml").string();
    req.dirs = test::dataDirs();
    req.clock = ClockKind::Sim;
    req.cameraThreads = 17;
    req.outputs = {"y4m:" + (d / "x.y4m").string()};
    EXPECT_THROW(runScenario(req, stderr), SetupError);
    std::filesystem::remove_all(d);
}

}  // namespace
}  // namespace nvs::rt
