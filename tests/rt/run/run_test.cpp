// `nvstim run` end to end: a candump flight log drives the pose; two sim-clock runs are byte
// identical; ffmpeg decodes every y4m frame from a pipe; the wall clock keeps 60 Hz; a file
// sink that runs out of space leaves nothing behind.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "drivers/can/can.h"
#include "test_paths.h"

namespace nvs {
namespace {

namespace fs = std::filesystem;

struct Result {
    int status = -1;
    std::string out;
};

Result sh(const std::string& cmd) {
    Result r;
    FILE* p = popen(cmd.c_str(), "r");
    if (p == nullptr) return r;
    std::array<char, 4096> buf{};
    std::size_t n = 0;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0)
        r.out.append(buf.data(), n);
    const int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

std::string slurp(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

class RunTest : public ::testing::Test {
  protected:
    void SetUp() override {
        dir_ = fs::temp_directory_path() /
               ("nvs_run_test_" + std::to_string(::getpid()) + "_" +
                ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::remove_all(dir_);
        fs::create_directories(dir_);
        std::ofstream(dir_ / "scenario.toml") << "[scenario]\n"
                                                 "name = \"replay flight\"\n"
                                                 "frame_rate_hz = 60\n"
                                                 "width = 64\n"
                                                 "height = 48\n"
                                                 "[runtime]\n"
                                                 "stale_after_s = 0.5\n"
                                                 "[[source]]\n"
                                                 "kind = \"test_pattern\"\n";
    }
    void TearDown() override { fs::remove_all(dir_); }

    // A 3-s flight: position at 10 Hz moving north, attitude at 50 Hz turning at 10°/s,
    // one unknown identifier and one truncated frame in between.
    fs::path writeFlight() {
        const auto db = drivers::DbcDatabase::load(
            (test::sourceDir() / "config" / "can" / "nvstim.dbc").string());
        const drivers::DbcMessage* pos = db.findByName("NVS_POSITION");
        const drivers::DbcMessage* att = db.findByName("NVS_ATTITUDE");
        const fs::path log = dir_ / "flight.log";
        std::ofstream out(log);
        const double t0 = 1700000000.0;
        char line[256];
        for (int i = 0; i <= 150; ++i) {
            const double t = i * 0.02;
            drivers::CanFrame f;
            f.id = att->id;
            f.len = static_cast<std::uint8_t>(att->size);
            for (const auto& s : att->signals) {
                const double v =
                    s.name == "Yaw_deg" ? 10.0 * t : (s.name == "Pitch_deg" ? 2.0 : 0.0);
                drivers::encodeSignal(s, v, f.data, f.len);
            }
            drivers::formatCandumpLine(t0 + t, "can0", f, line, sizeof line);
            out << line;
            if (i == 50) {
                out << "(1700000001.000000) can0 7FF#0102\n";  // unknown id
                out << "(1700000001.000000) can0 100#0102\n";  // truncated position
                out << "garbage line\n";
            }
            if (i % 5 == 0) {
                drivers::CanFrame p;
                p.id = pos->id;
                p.len = 8;
                drivers::encodeSignal(pos->signals[0], 47.0 + 1e-4 * t, p.data, p.len);
                drivers::encodeSignal(pos->signals[1], 8.5, p.data, p.len);
                drivers::formatCandumpLine(t0 + t, "can0", p, line, sizeof line);
                out << line;
            }
        }
        return log;
    }

    fs::path dir_;
};

TEST_F(RunTest, ReplayDrivesThePoseAndSimRunsAreByteIdentical) {
    const fs::path log = writeFlight();
    std::string outputs[2];
    std::string metas[2];
    for (int run = 0; run < 2; ++run) {
        const std::string tag = std::to_string(run);
        const Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                            " --clock sim --frames 150 --telemetry replay:" + log.string() +
                            " --output y4m:" + (dir_ / ("v" + tag + ".y4m")).string() +
                            " --output meta:" + (dir_ / ("m" + tag + ".jsonl")).string() +
                            " --stats " + (dir_ / ("s" + tag + ".json")).string() + " 2>&1");
        ASSERT_EQ(r.status, 0) << r.out;
        outputs[run] = slurp(dir_ / ("v" + tag + ".y4m"));
        metas[run] = slurp(dir_ / ("m" + tag + ".jsonl"));
    }
    ASSERT_GT(outputs[0].size(), 150u * 64 * 48);
    EXPECT_TRUE(outputs[0] == outputs[1]) << "video differs between two sim runs";
    EXPECT_TRUE(metas[0] == metas[1]) << "metadata differs between two sim runs";

    // The pose follows the flight: yaw = 10°/s · t (interpolated or extrapolated along the
    // straight track; the DBC's yaw resolution is 0.01°) once two attitude samples have been
    // received (frame k is rendered at t_(k−1), so from t = 0.05 s).
    std::istringstream in(metas[0]);
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
        const double t = std::stod(line.substr(line.find("\"t_sample_s\":") + 13));
        const double yaw = std::stod(line.substr(line.find("\"yaw_deg\":") + 10));
        const double pitch = std::stod(line.substr(line.find("\"pitch_deg\":") + 12));
        if (t >= 0.05) {
            EXPECT_NEAR(yaw, 10.0 * t, 0.011) << line;
        }
        EXPECT_NEAR(pitch, 2.0, 0.011);
        EXPECT_NE(line.find("\"pose_from_telemetry\":true"), std::string::npos);
        ++n;
    }
    EXPECT_EQ(n, 150);
    // Bad input counted, not fatal; latency reported.
    const std::string stats = slurp(dir_ / "s0.json");
    EXPECT_NE(stats.find("unknown id 1, truncated 1, out of range 0, bad lines 1"),
              std::string::npos)
        << stats;
    EXPECT_NE(stats.find("\"latency\":{\"n\":150"), std::string::npos) << stats;
}

TEST_F(RunTest, FfmpegDecodesEveryFrameFromAPipe) {
    if (sh("command -v ffmpeg").status != 0) GTEST_SKIP() << "ffmpeg not installed";
    const Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                        " --clock sim --frames 90 --output y4m:- 2>/dev/null | ffmpeg -v error "
                        "-f yuv4mpegpipe -i - -f framemd5 - | grep -c '^0,'");
    EXPECT_EQ(std::stoi(r.out), 90) << r.out;
}

TEST_F(RunTest, WallClockKeepsSixtyHertzForThreeSeconds) {
    const fs::path stats = dir_ / "stats.json";
    const Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                        " --clock wall --frames 180 --output meta:" + (dir_ / "m.jsonl").string() +
                        " --stats " + stats.string() + " 2>&1");
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string s = slurp(stats);
    const auto num = [&](const std::string& key, std::size_t from) {
        return std::stod(s.substr(s.find(key, from) + key.size()));
    };
    const std::size_t period = s.find("\"period\":");
    EXPECT_NEAR(num("\"p50_s\":", period), 1.0 / 60.0, 2e-4) << s;
    EXPECT_EQ(num("\"frames_emitted\":", 0), 180.0);
    EXPECT_LE(num("\"deadline_misses\":", 0), 3.0) << s;
}

TEST_F(RunTest, AFullDiskLeavesNothingCorruptBehind) {
    // A 64-KiB file-size limit stands in for a full disk: writes fail with EFBIG.
    const fs::path out = dir_ / "video.y4m";
    const Result r = sh("ulimit -f 64; " + std::string(NVSTIM_EXE) + " run " +
                        (dir_ / "scenario.toml").string() +
                        " --clock sim --frames 60 --output y4m:" + out.string() +
                        " --output meta:" + (dir_ / "m.jsonl").string() + " 2>&1");
    EXPECT_EQ(r.status, 0) << r.out;  // counted, not fatal (sink_errors = "count")
    EXPECT_FALSE(fs::exists(out)) << "a truncated video was left behind";
    EXPECT_FALSE(fs::exists(out.string() + ".part"));
    EXPECT_TRUE(fs::exists(dir_ / "m.jsonl"));  // the other output is complete
    EXPECT_NE(r.out.find("File too large"), std::string::npos) << r.out;
}

// A script's background job starts with SIGINT ignored (no job control); `kill -INT` must still
// stop the run cleanly: last frame finished, outputs closed, statistics written, exit 0.
TEST_F(RunTest, SigintStopsABackgroundRunStartedWithSigintIgnored) {
    const fs::path stats = dir_ / "stats.json";
    const std::string cmd = "trap '' INT; " + std::string(NVSTIM_EXE) + " run " +
                            (dir_ / "scenario.toml").string() +
                            " --clock wall --output meta:" + (dir_ / "m.jsonl").string() +
                            " --stats " + stats.string() +
                            " 2>/dev/null & pid=$!; sleep 0.5; kill -INT $pid; "
                            "for i in 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16 17 18 19 20; do "
                            "kill -0 $pid 2>/dev/null || break; sleep 0.1; done; "
                            "if kill -0 $pid 2>/dev/null; then kill -KILL $pid; echo hung; fi; "
                            "wait $pid; echo rc=$?";
    const Result r = sh(cmd);
    EXPECT_EQ(r.out.find("hung"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("rc=0"), std::string::npos) << r.out;
    EXPECT_TRUE(fs::exists(stats));
    EXPECT_TRUE(fs::exists(dir_ / "m.jsonl"));
}

TEST_F(RunTest, BadArgumentsAreOneLineSetupErrors) {
    Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                  " --clock sim --frames 2 --output bogus:x 2>&1");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.out.find("bogus"), std::string::npos) << r.out;
    std::ofstream(dir_ / "bad.toml") << "[scenario]\nname = \"x\"\nframe_rate = 60\n[[source]]\n"
                                        "kind = \"test_pattern\"\n";
    r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "bad.toml").string() +
           " --clock sim --frames 2 2>&1");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.out.find("bad.toml:3"), std::string::npos) << r.out;
}

// Interlaced frame-rate output through nvstim run with the IICCD camera (field-scan NTSC
// preset): 29.97 Hz frames, each woven from two 59.94 Hz fields; the metadata's t_sample_s is
// each frame's second field, one NTSC frame period apart.
TEST_F(RunTest, InterlacedScenarioRunsTheCameraPerField) {
    std::ofstream(dir_ / "il.toml") << "[scenario]\nname = \"il\"\nscan = \"interlaced\"\n"
                                       "width = 64\nheight = 48\n"
                                       "[camera]\npreset = \"pulnix-ag5745ef3\"\n"
                                       "[[source]]\nkind = \"test_pattern\"\n";
    const Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "il.toml").string() +
                        " --clock sim --frames 6 --output meta:" + (dir_ / "m.jsonl").string() +
                        " --stats " + (dir_ / "s.json").string() + " 2>&1");
    ASSERT_EQ(r.status, 0) << r.out;
    const std::string stats = slurp(dir_ / "s.json");
    EXPECT_NE(stats.find("\"scan\":\"interlaced\""), std::string::npos) << stats;
    EXPECT_NE(stats.find("\"frame_rate_hz\":29.970030"), std::string::npos) << stats;
    std::istringstream in(slurp(dir_ / "m.jsonl"));
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
        const double t = std::stod(line.substr(line.find("\"t_sample_s\":") + 13));
        EXPECT_NEAR(t, n * 1001.0 / 30000.0, 1e-9) << line;
        ++n;
    }
    EXPECT_EQ(n, 6);
}

// A trigger input that does not exist stops the setup with a message naming it (--clock wall);
// under --clock sim the trigger is not used and the scenario runs at its nominal rate.
TEST_F(RunTest, TriggerIsAWallClockDevice) {
    std::ofstream(dir_ / "tr.toml") << "[scenario]\nname = \"tr\"\nwidth = 32\nheight = 32\n"
                                       "[runtime]\ntrigger = \"gpio:nvs-no-such-chip:4\"\n"
                                       "[[source]]\nkind = \"test_pattern\"\n";
    Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "tr.toml").string() +
                  " --clock wall --frames 3 2>&1");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_NE(r.out.find("gpio:nvs-no-such-chip:4"), std::string::npos) << r.out;
    r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "tr.toml").string() +
           " --clock sim --frames 3 --stats " + (dir_ / "s.json").string() + " 2>&1");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("trigger is not used with --clock sim"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace nvs
