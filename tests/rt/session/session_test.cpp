// rt::Session, the run whose frames a caller pulls: the same frames as `nvstim run`'s y4m output
// of the same run (another path through the same engine: the command line, its sink, a file);
// every frame reaches a caller that is slower than the loop's one-second drain; stop() ends a
// long run early; setup errors reach the caller before any frame.
#include "rt/session/session.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <thread>

#include "sim/core/error.h"
#include "test_paths.h"

namespace nvs::rt {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

DataDirs dirs() {
    return {test::configDir(), fs::path(NVS_BINARY_DIR) / "cache"};
}

// A y4m stream's frame payloads (the header's and each FRAME line stripped).
std::vector<std::string> y4mFrames(const std::string& y4m, std::size_t frameBytes) {
    std::vector<std::string> frames;
    std::size_t pos = y4m.find('\n');
    while (pos != std::string::npos && pos + 1 < y4m.size()) {
        const std::size_t line = y4m.find('\n', pos + 1);
        if (line == std::string::npos || y4m.compare(pos + 1, 5, "FRAME") != 0) break;
        frames.push_back(y4m.substr(line + 1, frameBytes));
        pos = line + frameBytes;
    }
    return frames;
}

// The bytes a y4m output writes for a frame of `bits` significant bits (drivers/sinks: the
// samples shifted to the top of 8 or 16 bits, 16-bit little-endian).
std::string asY4m(const PulledFrame& f) {
    std::string out;
    for (const std::uint16_t v : f.counts) {
        if (f.bits > 8) {
            const auto s = static_cast<std::uint16_t>(f.bits >= 16 ? v : v << (16 - f.bits));
            out.push_back(static_cast<char>(s & 0xff));
            out.push_back(static_cast<char>(s >> 8));
        } else {
            out.push_back(static_cast<char>(v << (8 - f.bits)));
        }
    }
    return out;
}

class SessionTest : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("nvs_session_test_" + std::to_string(::getpid()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
    }
    void TearDown() override { fs::remove_all(dir_); }
    // A 32 × 16 test pattern (no camera) of n frames, as the options of a session.
    SessionOptions pattern(std::int64_t frames) const {
        std::ofstream(dir_ / "scenario.toml")
            << "[scenario]\nname = \"pattern\"\nwidth = 32\n"
               "height = 16\n[[source]]\nkind = \"test_pattern\"\n";
        SessionOptions o;
        o.scenario = (dir_ / "scenario.toml").string();
        o.frames = frames;
        o.dirs = dirs();
        return o;
    }
    fs::path dir_;
};

// The shipped default night (an interlaced RS-170 camera), shrunk with --set, 5 frames: the
// pulled frames are the bytes `nvstim run --output y4m:` writes for the same command line, and
// the metadata the records of its meta: output.
TEST_F(SessionTest, PulledFramesAreTheCommandLinesY4mFrames) {
    const fs::path scenario = test::sourceDir() / "scenarios" / "thesis-nolight";
    const fs::path y4m = dir_ / "x.y4m", meta = dir_ / "x.jsonl";
    const std::string cmd =
        std::string("NVS_CONFIG_DIR=") + test::configDir().string() +
        " NVS_CACHE_DIR=" + NVS_BINARY_DIR + "/cache " + NVSTIM_EXE + " run " + scenario.string() +
        " --clock sim --frames 5 --set width=96 --set height=64 --output y4m:" + y4m.string() +
        " --output meta:" + meta.string() + " 2>/dev/null";
    const int st = std::system(cmd.c_str());
    ASSERT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == 0) << cmd;

    SessionOptions o;
    o.scenario = scenario.string();
    o.frames = 5;
    o.overrides.cameraSets = {{"width", "96"}, {"height", "64"}};
    o.dirs = dirs();
    Session s(o);
    EXPECT_EQ(s.width(), 96);
    EXPECT_EQ(s.height(), 64);
    EXPECT_EQ(s.fieldOrder(), msg::FieldOrder::TopFirst);  // the preset's RS-170 fields
    const std::size_t frameBytes = 96u * 64u * (s.bits() > 8 ? 2u : 1u);
    const std::vector<std::string> expected = y4mFrames(slurp(y4m), frameBytes);
    ASSERT_EQ(expected.size(), 5u);
    std::istringstream records(slurp(meta));
    PulledFrame f;
    int n = 0;
    while (s.next(f)) {
        ASSERT_LT(n, 5);
        EXPECT_EQ(asY4m(f), expected[static_cast<std::size_t>(n)]) << "frame " << n;
        std::string record;
        std::getline(records, record);
        EXPECT_EQ(f.metaJson, record) << "frame " << n;
        EXPECT_EQ(f.index, n);
        ++n;
    }
    EXPECT_EQ(n, 5);
    EXPECT_EQ(s.finish(), 0);
}

// A test pattern's 12 frames through a ring of 2, the caller asleep for 1.5 s (longer than the
// loop waits for a stalled output at the end of a run) before it takes any: all 12 arrive, in
// order, and the run ends with status 0.
TEST_F(SessionTest, ASlowCallerGetsEveryFrame) {
    SessionOptions o = pattern(12);
    o.depth = 2;
    Session s(o);
    std::this_thread::sleep_for(std::chrono::milliseconds(1500));
    PulledFrame f;
    std::int64_t expect = 0;
    while (s.next(f))
        EXPECT_EQ(f.index, expect++);
    EXPECT_EQ(expect, 12);
    EXPECT_EQ(s.finish(), 0);
}

// stop() ends a run of a million frames: next() drains and returns false, the status says
// interrupted (8), as SIGINT would for `nvstim run`.
TEST_F(SessionTest, StopEndsALongRun) {
    const SessionOptions o = pattern(1'000'000);
    Session s(o);
    PulledFrame f;
    for (int i = 0; i < 3; ++i)
        ASSERT_TRUE(s.next(f));
    s.stop();
    int more = 0;
    while (s.next(f) && more < 100)
        ++more;
    EXPECT_LT(more, 100);
    EXPECT_EQ(s.finish(), kRunInterrupted);
}

// Setup errors are thrown by the constructor, with the command line's words.
TEST_F(SessionTest, SetupErrorsReachTheCaller) {
    SessionOptions o;
    o.dirs = dirs();
    o.scenario = (dir_ / "none").string();
    EXPECT_THROW(Session{o}, SetupError);
    o.scenario = (test::sourceDir() / "scenarios" / "rit-fusion").string();
    try {
        Session s(o);
        FAIL() << "a rig without a channel name was accepted";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("name a channel"), std::string::npos) << e.what();
    }
    o.scenario = (test::sourceDir() / "scenarios" / "thesis-nolight").string();
    o.overrides.cameraSets = {{"width", "wide"}};
    try {
        Session s(o);
        FAIL() << "--set width=wide was accepted";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("--set width=wide"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace nvs::rt
