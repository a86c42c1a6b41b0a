// nvstim replay --bless / --check on a small scenario of known output.
#include "rt/replay/replay.h"

#include <gtest/gtest.h>

#include <fstream>
#include <regex>

#include "sim/core/error.h"

namespace nvs::rt {
namespace {
namespace fs = std::filesystem;

const char* kScenario = R"(
[scenario]
name = "replay-test"
frame_rate_hz = 30
width = 64
height = 48
bits = 8
duration_s = 1.0

[[source]]
kind = "test_pattern"
radiance_max_W_m2_sr = 1e-4
full_scale_W_m2_sr = 1e-4
target_speed_px_s = 20
)";

fs::path makeScenario(const char* name, const std::string& text) {
    const fs::path d = fs::temp_directory_path() / name;
    fs::remove_all(d);
    fs::create_directories(d);
    std::ofstream(d / "scenario.toml") << text;
    return d;
}

std::string readFile(const fs::path& p) {
    std::ifstream in(p);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(Replay, BlessThenCheckPassesBitExact) {
    const fs::path d = makeScenario("nvs_replay_ok", kScenario);
    blessScenario(d, NVSTIM_EXE);
    ASSERT_TRUE(fs::exists(d / "expected" / "digest.toml"));
    ASSERT_TRUE(fs::exists(d / "expected" / "w0_mean.pfm"));
    const std::string digest = readFile(d / "expected" / "digest.toml");
    EXPECT_NE(digest.find("frames = 30"), std::string::npos) << digest;
    const ReplayResult r = checkScenario(d, NVSTIM_EXE);
    EXPECT_TRUE(r.passed) << r.report;
    EXPECT_NE(r.report.find("all 30 frames and the metadata are identical"), std::string::npos)
        << r.report;
    EXPECT_FALSE(fs::exists(d / "check-failures"));
}

// A deliberate change in what the scenario produces fails with a readable diff: which frames
// moved, which window statistics moved and by how much, and error images.
TEST(Replay, ChangedOutputFailsWithReadableDiff) {
    const fs::path d = makeScenario("nvs_replay_change", kScenario);
    blessScenario(d, NVSTIM_EXE);
    std::string changed = kScenario;
    changed.replace(changed.find("radiance_max_W_m2_sr = 1e-4"), 27,
                    "radiance_max_W_m2_sr = 8e-5");  // 20 % dimmer scene
    std::ofstream(d / "scenario.toml") << changed;
    const ReplayResult r = checkScenario(d, NVSTIM_EXE);
    EXPECT_FALSE(r.passed);
    EXPECT_TRUE(
        std::regex_search(r.report, std::regex("bit-exact: 30 of 30 frames differ \\(0, 1, 2")))
        << r.report;
    EXPECT_TRUE(std::regex_search(r.report,
                                  std::regex("window 0 \\(frames 0-29\\): mean [0-9.]+ -> [0-9.]+ "
                                             "counts, moved in [1-9][0-9]* of 48 blocks")))
        << r.report;
    EXPECT_TRUE(fs::exists(d / "check-failures" / "w0_z.pgm"));
    // Blessing the change makes it the new expectation.
    blessScenario(d, NVSTIM_EXE);
    EXPECT_TRUE(checkScenario(d, NVSTIM_EXE).passed);
}

// On another build the digests are not comparable; the statistics decide.
TEST(Replay, OtherBuildFallsBackToStatistics) {
    const fs::path d = makeScenario("nvs_replay_other", kScenario);
    blessScenario(d, NVSTIM_EXE);
    std::string digest = readFile(d / "expected" / "digest.toml");
    digest = std::regex_replace(digest, std::regex("fingerprint = \"[^\"]*\""),
                                "fingerprint = \"other compiler\"");
    digest = std::regex_replace(digest, std::regex("frame_sha256 = \\[\n  \"[0-9a-f]+\""),
                                "frame_sha256 = [\n  \"00\"");
    std::ofstream(d / "expected" / "digest.toml") << digest;
    const ReplayResult r = checkScenario(d, NVSTIM_EXE);
    EXPECT_TRUE(r.passed) << r.report;
    EXPECT_NE(r.report.find("digests are not comparable, the statistics decide"), std::string::npos)
        << r.report;
}

TEST(Replay, BadFoldersAreClearErrors) {
    EXPECT_THROW(checkScenario("/nonexistent/scn", NVSTIM_EXE), SetupError);
    const fs::path d = makeScenario("nvs_replay_noexp", kScenario);
    try {
        checkScenario(d, NVSTIM_EXE);
        FAIL();
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("--bless"), std::string::npos) << e.what();
    }
    const fs::path bad = makeScenario(
        "nvs_replay_bad",
        "[scenario]\nname = \"x\"\nfram_rate_hz = 30\n[[source]]\nkind = \"test_pattern\"\n");
    try {
        blessScenario(bad, NVSTIM_EXE);
        FAIL();
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("fram_rate_hz"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace nvs::rt
