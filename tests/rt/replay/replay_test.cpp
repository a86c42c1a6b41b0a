// nvstim replay --bless / --check on a small scenario of known output.
#include "rt/replay/replay.h"

#include <gtest/gtest.h>
#include <signal.h>
#include <stdlib.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <regex>
#include <stdexcept>
#include <thread>
#include <vector>

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

// Each scenario in a private folder of its own (mkdtemp), so that tests running in parallel
// (ctest -j) never share one; removed at the end of the test binary.
fs::path makeScenario(const char* name, const std::string& text) {
    std::string tmpl = (fs::temp_directory_path() / (std::string(name) + "-XXXXXX")).string();
    if (::mkdtemp(tmpl.data()) == nullptr) throw std::runtime_error("mkdtemp failed");
    const fs::path d = tmpl;
    std::ofstream(d / "scenario.toml") << text;
    static std::vector<fs::path> made;
    static const struct Cleanup {
        ~Cleanup() {
            for (const auto& p : made) {
                std::error_code ec;
                fs::remove_all(p, ec);
            }
        }
    } cleanup;
    made.push_back(d);
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
    EXPECT_NE(r.report.find("checked: digests (bit-exact"), std::string::npos) << r.report;
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
                                "frame_sha256 = [\n  \"" + std::string(64, '0') + "\"");
    std::ofstream(d / "expected" / "digest.toml") << digest;
    const ReplayResult r = checkScenario(d, NVSTIM_EXE);
    EXPECT_TRUE(r.passed) << r.report;
    EXPECT_NE(r.report.find("checked: statistics only (blessed on \"other compiler\""),
              std::string::npos)
        << r.report;
}

// Blessed on the same build but another instruction set (SSE4.2, or AVX2 where this CPU is an
// SSE4.2 one): the report says what the check was, and that only the ISA differs.
TEST(Replay, OtherIsaSaysStatisticsDecided) {
    const fs::path d = makeScenario("nvs_replay_isa", kScenario);
    blessScenario(d, NVSTIM_EXE);
    std::string digest = readFile(d / "expected" / "digest.toml");
    const std::string mine = buildFingerprint();
    ASSERT_NE(digest.find(mine), std::string::npos) << digest;
    const std::string otherIsa = isaFingerprint() == "sse4.2" ? "avx2" : "sse4.2";
    const std::string other =
        std::regex_replace(mine, std::regex("x86_64\\+[^ ]+"), "x86_64+" + otherIsa);
    ASSERT_NE(other, mine);
    EXPECT_EQ(fingerprintWithoutIsa(other), fingerprintWithoutIsa(mine));
    digest.replace(digest.find(mine), mine.size(), other);
    std::ofstream(d / "expected" / "digest.toml") << digest;
    const ReplayResult same = checkScenario(d, NVSTIM_EXE);
    EXPECT_TRUE(same.passed) << same.report;
    EXPECT_NE(same.report.find("where the digests need not hold, and they hold"), std::string::npos)
        << same.report;
    digest = std::regex_replace(digest, std::regex("frame_sha256 = \\[\n  \"[0-9a-f]+\""),
                                "frame_sha256 = [\n  \"" + std::string(64, '0') + "\"");
    std::ofstream(d / "expected" / "digest.toml") << digest;
    const ReplayResult r = checkScenario(d, NVSTIM_EXE);
    EXPECT_TRUE(r.passed) << r.report;
    EXPECT_NE(r.report.find("checked: statistics only"), std::string::npos) << r.report;
    EXPECT_NE(r.report.find("same build on ISA \"" + isaFingerprint() + "\""), std::string::npos)
        << r.report;
}

TEST(Replay, FingerprintNamesTheIsa) {
    const std::string fp = buildFingerprint();
    EXPECT_NE(fp.find("+" + isaFingerprint() + " "), std::string::npos) << fp;
    EXPECT_EQ(fingerprintWithoutIsa("gcc 12.2.0 x86_64+avx2 RelWithDebInfo glibc 2.36"),
              "gcc 12.2.0 x86_64 RelWithDebInfo glibc 2.36");
    EXPECT_EQ(
        fingerprintWithoutIsa("gcc 12.2.0 x86_64+avx512f RelWithDebInfo glibc 2.36"),
        fingerprintWithoutIsa("gcc 12.2.0 x86_64+sse2/embree-sse2 RelWithDebInfo glibc 2.36"));
    EXPECT_NE(fingerprintWithoutIsa("gcc 12.2.0 x86_64+avx2 Debug glibc 2.36"),
              fingerprintWithoutIsa("gcc 12.2.0 x86_64+avx2 RelWithDebInfo glibc 2.36"));
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

// Rewrites a key's value in an expectation file (the whole line).
void setLine(const fs::path& file, const std::string& key, const std::string& value) {
    std::string text = readFile(file);
    text = std::regex_replace(text, std::regex("(^|\n)" + key + " = [^\n]*"),
                              "$1" + key + " = " + value);
    std::ofstream(file, std::ios::trunc) << text;
}

std::string checkError(const fs::path& d) {
    try {
        const ReplayResult r = checkScenario(d, NVSTIM_EXE);
        return r.passed ? "passed" : "failed: " + r.report;
    } catch (const SetupError& e) {
        return e.what();
    }
}

// An expectation that could not tell a good replay from a bad one is an error, never a pass:
// an empty digest list (before: passed), a digest count that is not the frame count.
TEST(Replay, EmptyOrInconsistentDigestsFailClosed) {
    const fs::path d = makeScenario("nvs_replay_empty", kScenario);
    blessScenario(d, NVSTIM_EXE);
    const fs::path digest = d / "expected" / "digest.toml";
    const std::string good = readFile(digest);
    std::string text =
        std::regex_replace(good, std::regex("frame_sha256 = \\[[^\\]]*\\]"), "frame_sha256 = []");
    std::ofstream(digest, std::ios::trunc)
        << std::regex_replace(text, std::regex("frames = 30"), "frames = 0");
    std::string e = checkError(d);
    EXPECT_NE(e.find("digest.toml:"), std::string::npos) << e;
    EXPECT_NE(e.find("at least 1"), std::string::npos) << e;
    std::ofstream(digest, std::ios::trunc) << text;  // 30 frames, no digests
    e = checkError(d);
    EXPECT_NE(e.find("lists 0 digests for 30 frames"), std::string::npos) << e;
    std::ofstream(digest, std::ios::trunc) << good;
    setLine(digest, "meta_sha256", "\"\"");
    e = checkError(d);
    EXPECT_NE(e.find("meta_sha256"), std::string::npos) << e;
}

// A window outside the run, or one whose end overflows, is an error naming the line (before:
// an int overflow passed the range check and the replay read outside its frame list: SIGSEGV).
TEST(Replay, WindowsOutsideTheRunAreErrors) {
    const fs::path d = makeScenario("nvs_replay_window", kScenario);
    blessScenario(d, NVSTIM_EXE);
    const fs::path stats = d / "expected" / "stats.toml";
    const std::string good = readFile(stats);
    for (const auto& [key, value] :
         std::vector<std::pair<std::string, std::string>>{{"first", "2147483600"},
                                                          {"first", "-5"},
                                                          {"count", "2147483647"},
                                                          {"count", "0"},
                                                          {"count", "31"}}) {
        std::ofstream(stats, std::ios::trunc) << good;
        setLine(stats, key, value);
        const std::string e = checkError(d);
        EXPECT_NE(e.find("stats.toml:"), std::string::npos) << key << "=" << value << ": " << e;
        EXPECT_NE(e.find(key), std::string::npos) << e;
    }
    // No window at all.
    std::ofstream(stats, std::ios::trunc) << "block_px = 8\n";
    EXPECT_NE(checkError(d).find("no [[window]]"), std::string::npos) << checkError(d);
}

// Non-finite references fail closed (before: every comparison with NaN was false: a pass).
TEST(Replay, NonFiniteReferencesAreErrors) {
    const fs::path d = makeScenario("nvs_replay_nan", kScenario);
    blessScenario(d, NVSTIM_EXE);
    const fs::path stats = d / "expected" / "stats.toml";
    const std::string good = readFile(stats);
    setLine(stats, "level_counts", "nan");
    EXPECT_NE(checkError(d).find("level_counts"), std::string::npos) << checkError(d);
    std::ofstream(stats, std::ios::trunc) << good;
    // A NaN in a reference image.
    const fs::path pfm = d / "expected" / "w0_mean.pfm";
    std::string img = readFile(pfm);
    const float nan = std::nanf("");
    std::memcpy(img.data() + img.size() - sizeof nan, &nan, sizeof nan);
    std::ofstream(pfm, std::ios::binary | std::ios::trunc) << img;
    const std::string e = checkError(d);
    EXPECT_NE(e.find("w0_mean.pfm"), std::string::npos) << e;
    EXPECT_NE(e.find("not finite"), std::string::npos) << e;
}

// --bless never deletes through a symbolic link named expected/ (before: it emptied the folder
// the link pointed to), and removes only the files it writes itself.
TEST(Replay, BlessNeverDeletesThroughALinkOrWhatItDidNotWrite) {
    const fs::path d = makeScenario("nvs_replay_link", kScenario);
    const fs::path elsewhere = makeScenario("nvs_replay_elsewhere", kScenario);
    std::ofstream(elsewhere / "precious.txt") << "keep me\n";
    fs::create_directory_symlink(elsewhere, d / "expected");
    try {
        blessScenario(d, NVSTIM_EXE);
        FAIL() << "blessed through a symbolic link";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("symbolic link"), std::string::npos) << e.what();
    }
    EXPECT_TRUE(fs::exists(elsewhere / "precious.txt"));
    EXPECT_TRUE(fs::exists(elsewhere / "scenario.toml"));
    fs::remove(d / "expected");
    fs::create_directory(d / "expected");
    std::ofstream(d / "expected" / "NOTES.md") << "why these expectations\n";
    blessScenario(d, NVSTIM_EXE);
    blessScenario(d, NVSTIM_EXE);  // a second bless replaces its own files
    EXPECT_TRUE(fs::exists(d / "expected" / "NOTES.md"));
    EXPECT_TRUE(checkScenario(d, NVSTIM_EXE).passed);
}

// With SIGCHLD ignored by the parent (a daemon, some CI runners), --check still gets its child's
// status and does not spin (before: waitpid failed with ECHILD forever at 100 % CPU).
TEST(Replay, CheckWorksWhenSigchldIsIgnored) {
    const fs::path d = makeScenario("nvs_replay_sigchld", kScenario);
    blessScenario(d, NVSTIM_EXE);
    struct sigaction ign {
    }, old{};
    ign.sa_handler = SIG_IGN;
    sigemptyset(&ign.sa_mask);
    sigaction(SIGCHLD, &ign, &old);
    std::atomic<bool> done{false};
    std::thread watchdog([&] {
        for (int i = 0; i < 600 && !done.load(); ++i)
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
        if (!done.load()) {
            std::fprintf(stderr, "replay --check did not return within 60 s\n");
            std::_Exit(1);
        }
    });
    const ReplayResult r = checkScenario(d, NVSTIM_EXE);
    done.store(true);
    watchdog.join();
    struct sigaction now {};
    sigaction(SIGCHLD, &old, &now);
    EXPECT_TRUE(r.passed) << r.report;
    EXPECT_EQ(now.sa_handler, SIG_IGN);  // the caller's disposition is given back
}

// Plain replay writes into a private folder of its own: two at once never share one.
TEST(Replay, PlainReplayUsesAPrivateFolder) {
    const fs::path d = makeScenario("nvs_replay_plain", kScenario);
    const fs::path a = makeReplayTempDir(), b = makeReplayTempDir();
    EXPECT_NE(a, b);
    EXPECT_EQ(fs::status(a).permissions() & fs::perms::all, fs::perms::owner_all);
    const fs::path frames = replayScenario(d, NVSTIM_EXE, a);
    EXPECT_EQ(frames, a / "frames");
    EXPECT_TRUE(fs::exists(a / "meta.jsonl"));
    fs::remove_all(a);
    fs::remove_all(b);
}

}  // namespace
}  // namespace nvs::rt
