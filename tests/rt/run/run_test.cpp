// `nvstim run` end to end: a candump flight log drives the pose; two sim-clock runs are byte
// identical; ffmpeg decodes every y4m frame from a pipe; the wall clock keeps 60 Hz; a file
// sink that runs out of space leaves nothing behind.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <time.h>

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
    // The cadence is the claim (median period); on a shared 2-core machine a few ticks may be
    // lost to other load, so up to 5 % of them may be missed or skipped, no more.
    EXPECT_NEAR(num("\"p50_s\":", period), 1.0 / 60.0, 2e-4) << s;
    EXPECT_GE(num("\"frames_emitted\":", 0), 171.0) << s;
    EXPECT_LE(num("\"deadline_misses\":", 0), 9.0) << s;
}

// --stats gives the run clock's origin on CLOCK_MONOTONIC (the clock of GPIO line events), from
// which a frame's exposure window is placed (tests/hil): between this process's readings of the
// clock before and after the run; 0 under the sim clock (no wall time).
TEST_F(RunTest, StatsGiveTheRunClocksOriginOnClockMonotonic) {
    const auto monotonic_ns = [] {
        timespec ts{};
        clock_gettime(CLOCK_MONOTONIC, &ts);
        return static_cast<long long>(ts.tv_sec) * 1000000000LL + ts.tv_nsec;
    };
    const std::string key = "\"clock_origin_ns\":";
    const long long before_ns = monotonic_ns();
    Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                  " --clock wall --frames 6 --stats " + (dir_ / "w.json").string() + " 2>&1");
    const long long after_ns = monotonic_ns();
    ASSERT_EQ(r.status, 0) << r.out;
    std::string s = slurp(dir_ / "w.json");
    ASSERT_NE(s.find(key), std::string::npos) << s;
    const long long origin_ns = std::stoll(s.substr(s.find(key) + key.size()));
    EXPECT_GT(origin_ns, before_ns) << s;
    // Six frames at 60 Hz after the origin: the run ends at least 5/60 s after it.
    EXPECT_LT(origin_ns, after_ns - 5 * 1000000000LL / 60) << s;
    r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
           " --clock sim --frames 2 --stats " + (dir_ / "s.json").string() + " 2>&1");
    ASSERT_EQ(r.status, 0) << r.out;
    s = slurp(dir_ / "s.json");
    EXPECT_NE(s.find(key + "0,"), std::string::npos) << s;
}

// A full disk keeps what was written: the y4m is cut back to its last whole frame and renamed
// into place (a valid stream), the run goes on with its other output and exits 4 (an output
// failed). Before: the whole video was deleted and the run exited 0.
TEST_F(RunTest, AFullDiskKeepsEveryWholeFrameWritten) {
    // A file-size limit stands in for a full disk: writes beyond it fail with EFBIG (dash's
    // `ulimit -f` counts 512-byte blocks: 32 KiB).
    const fs::path out = dir_ / "video.y4m";
    const Result r = sh("ulimit -f 64; " + std::string(NVSTIM_EXE) + " run " +
                        (dir_ / "scenario.toml").string() +
                        " --clock sim --frames 60 --output y4m:" + out.string() +
                        " --output meta:" + (dir_ / "m.jsonl").string() + " 2>&1");
    EXPECT_EQ(r.status, 4) << r.out;  // an output failed, the other went on
    EXPECT_NE(r.out.find("File too large"), std::string::npos) << r.out;
    EXPECT_FALSE(fs::exists(out.string() + ".part"));
    ASSERT_TRUE(fs::exists(out)) << "the frames written before the disk filled were deleted";
    const std::string v = slurp(out);
    const std::size_t header = v.find('\n') + 1;
    const std::size_t frameBytes = 6 + 64 * 48;
    ASSERT_GT(v.size(), header);
    EXPECT_EQ((v.size() - header) % frameBytes, 0u) << "a partial frame was kept";
    const std::size_t frames = (v.size() - header) / frameBytes;
    EXPECT_GE(frames, 5u);
    EXPECT_LT(frames, 60u);
    for (std::size_t k = 0; k < frames; ++k)
        EXPECT_EQ(v.compare(header + k * frameBytes, 6, "FRAME\n"), 0) << k;
    // The other output is complete.
    std::istringstream meta(slurp(dir_ / "m.jsonl"));
    std::string line;
    int n = 0;
    while (std::getline(meta, line))
        ++n;
    EXPECT_EQ(n, 60);
}

// The metadata stream on a full disk keeps whole lines only.
TEST_F(RunTest, AFullDiskKeepsTheMetadataWholeLines) {
    const fs::path meta = dir_ / "m.jsonl";
    const Result r =
        sh("ulimit -f 8; " + std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
           " --clock sim --frames 60 --output meta:" + meta.string() + " 2>&1");
    EXPECT_EQ(r.status, 1) << r.out;  // its only output failed: the run stopped
    EXPECT_NE(r.out.find("every output failed"), std::string::npos) << r.out;
    ASSERT_TRUE(fs::exists(meta));
    const std::string m = slurp(meta);
    ASSERT_FALSE(m.empty());
    EXPECT_EQ(m.back(), '\n') << "a half line was kept";
    EXPECT_LE(m.size(), 8u * 512u);
    std::istringstream in(m);
    std::string line;
    while (std::getline(in, line)) {
        EXPECT_EQ(line.front(), '{');
        EXPECT_EQ(line.back(), '}');
    }
}

// A consumer that stops reading (`| sleep`) holds up only its own output: the loop keeps its
// cadence, the other output gets every frame, the stalled one loses frames (counted as its
// queue drops), and the end of the run does not wait for the consumer.
TEST_F(RunTest, AStalledConsumerDelaysNeitherTheLoopNorAnotherOutput) {
    const fs::path stats = dir_ / "s.json";
    // The consumer: `sleep` holding the read end of a FIFO, never reading.
    const Result r =
        sh("cd " + dir_.string() + " && mkfifo pipe && { sleep 30 < pipe > /dev/null " +
           "2>&1 & sp=$!; } && " + std::string(NVSTIM_EXE) +
           " run scenario.toml --clock wall --frames 150 --output y4m:- " +
           "--output meta:m.jsonl --stats " + stats.string() +
           " > pipe 2>/dev/null; echo rc=$?; kill $sp");
    EXPECT_NE(r.out.find("rc=4"), std::string::npos) << r.out;  // y4m failed: cancelled
    const std::string s = slurp(stats);
    ASSERT_FALSE(s.empty());
    const auto num = [&](const std::string& key, std::size_t from = 0) {
        const std::size_t at = s.find(key, from);
        return at == std::string::npos ? -1.0 : std::stod(s.substr(at + key.size()));
    };
    // The cadence: a frame is missing from the count only where the loop missed its deadline
    // (on a loaded machine, by the machine, not by the consumer).
    const double misses = num("\"deadline_misses\":");
    EXPECT_LE(misses, 5.0) << s;
    EXPECT_GE(num("\"frames_emitted\":"), 150.0 - misses) << s;
    const std::size_t y4m = s.find("\"name\":\"y4m:-\"");
    const std::size_t sinks = s.find("\"sinks\":[");
    ASSERT_NE(y4m, std::string::npos) << s;
    EXPECT_GT(num("\"queue_drops\":", sinks), 100.0) << s;  // y4m is the first sink
    // The other output gets every frame the loop offered it (one per tick), none dropped.
    const std::size_t metaSink = s.find("\"offered\":", y4m);
    ASSERT_NE(metaSink, std::string::npos) << s;
    const double offered = num("\"offered\":", metaSink);
    EXPECT_EQ(num("\"written\":", metaSink), offered) << s;
    EXPECT_EQ(num("\"queue_drops\":", metaSink), 0.0) << s;
    std::istringstream meta(slurp(dir_ / "m.jsonl"));
    std::string line;
    int n = 0;
    while (std::getline(meta, line))
        ++n;
    EXPECT_EQ(n, offered);
    EXPECT_GE(n, 150 - misses);
    // 150 frames at 60 Hz take 2.5 s; the drain gives a blocked write up to 1 s.
    EXPECT_LT(num("\"elapsed_s\":"), 3.0) << s;
}

// SIGINT does not wait for a write blocked on a consumer that stopped reading; the exit status
// says the run was interrupted (8) and that an output failed (4).
TEST_F(RunTest, SigintDoesNotWaitForABlockedWrite) {
    const std::string cmd = "cd " + dir_.string() +
                            " && mkfifo pipe && { sleep 30 < pipe > /dev/null 2>&1 & sp=$!; } && " +
                            std::string(NVSTIM_EXE) + " run scenario.toml --clock wall " +
                            "--output y4m:- --output meta:m.jsonl > pipe 2>/dev/null & pid=$!; " +
                            "sleep 1.5; t0=$(date +%s%N); kill -INT $pid; "
                            "for i in $(seq 1 60); do kill -0 $pid 2>/dev/null || break; "
                            "sleep 0.05; done; t1=$(date +%s%N); "
                            "if kill -0 $pid 2>/dev/null; then kill -KILL $pid; echo hung; fi; "
                            "wait $pid; echo rc=$? ms=$(( (t1 - t0) / 1000000 )); kill $sp";
    const Result r = sh(cmd);
    EXPECT_EQ(r.out.find("hung"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("rc=12"), std::string::npos) << r.out;
    const std::size_t ms = r.out.find("ms=");
    ASSERT_NE(ms, std::string::npos) << r.out;
    EXPECT_LT(std::stoi(r.out.substr(ms + 3)), 1000) << r.out;
    EXPECT_TRUE(fs::exists(dir_ / "m.jsonl"));
}

// A consumer that goes away (EPIPE) fails its output: with another output the run goes on and
// exits 4; when it was the only one, every output has failed and the run stops with 1.
TEST_F(RunTest, AConsumerThatGoesAwayFailsItsOutput) {
    Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                  " --clock sim --frames 600 --output y4m:- --stats " + (dir_ / "s.json").string() +
                  " 2>" + (dir_ / "err").string() + " | head -c 100000 > /dev/null");
    std::string s = slurp(dir_ / "s.json");
    EXPECT_NE(s.find("\"failure\":\"stopping: every output failed\""), std::string::npos) << s;
    EXPECT_NE(s.find("\"outputs_failed\":1"), std::string::npos) << s;
    EXPECT_EQ(s.find("\"frames_emitted\":600"), std::string::npos) << "ran on with no output";
    // The status of the first command of a pipeline, without bash: through a file.
    r = sh("(" + std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
           " --clock sim --frames 600 --output y4m:- 2>/dev/null; echo $? > " +
           (dir_ / "rc1").string() + ") | head -c 100000 > /dev/null; (" + std::string(NVSTIM_EXE) +
           " run " + (dir_ / "scenario.toml").string() +
           " --clock sim --frames 600 --output y4m:- --output meta:" + (dir_ / "m.jsonl").string() +
           " 2>/dev/null; echo $? > " + (dir_ / "rc2").string() + ") | head -c 100000 > /dev/null");
    EXPECT_EQ(std::stoi(slurp(dir_ / "rc1")), 1);
    EXPECT_EQ(std::stoi(slurp(dir_ / "rc2")), 4);
    std::istringstream meta(slurp(dir_ / "m.jsonl"));
    std::string line;
    int n = 0;
    while (std::getline(meta, line))
        ++n;
    EXPECT_EQ(n, 600);
}

// A contact sheet that cannot be written fails at setup (exit 2, nothing run), not after the
// whole run with exit 0.
TEST_F(RunTest, AnUnwritableContactSheetFailsAtSetup) {
    fs::create_directories(dir_ / "sheet.png");
    for (const std::string& target :
         {(dir_ / "sheet.png").string(), std::string("/proc/sheet.png")}) {
        const Result r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                            " --clock sim --frames 30 --output contact:" + target +
                            " --output meta:" + (dir_ / "m.jsonl").string() + " 2>&1");
        EXPECT_EQ(r.status, 2) << r.out;
        EXPECT_NE(r.out.find("contact:" + target), std::string::npos) << r.out;
        EXPECT_FALSE(fs::exists(dir_ / "m.jsonl")) << "the run went ahead";
    }
}

// A script's background job starts with SIGINT ignored (no job control); `kill -INT` must still
// stop the run cleanly: last frame finished, outputs closed, statistics written, exit 8
// (interrupted).
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
    EXPECT_NE(r.out.find("rc=8"), std::string::npos) << r.out;
    EXPECT_TRUE(fs::exists(stats));
    EXPECT_NE(slurp(stats).find("\"interrupted\":true"), std::string::npos);
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
           " --clock sim --frames 2 --output y4m:/dev/null 2>&1");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.out.find("bad.toml:3"), std::string::npos) << r.out;
}

// Telemetry and the sim clock: CAN steps in lockstep with its time signal (so it is accepted and
// opens the bus), serial carries no time of its own (refused), idle_s belongs to the lockstep.
TEST_F(RunTest, SimClockTakesCanInLockstepButNotSerial) {
    // An output given: a run without one is refused before its telemetry is looked at.
    const std::string run = std::string(NVSTIM_EXE) + " run " + (dir_ / "scenario.toml").string() +
                            " --output y4m:/dev/null";
    Result r = sh(run + " --clock sim --frames 2 --telemetry can:nvsnosuch0 2>&1");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.out.find("can:nvsnosuch0: cannot open"), std::string::npos) << r.out;
    r = sh(run + " --clock sim --frames 2 --telemetry 'serial:/dev/null?proto=nmea' 2>&1");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.out.find("serial telemetry needs --clock wall"), std::string::npos) << r.out;
    r = sh(run + " --clock wall --frames 2 --telemetry 'can:nvsnosuch0?idle_s=1' 2>&1");
    EXPECT_EQ(r.status, 2);
    EXPECT_NE(r.out.find("idle_s needs --clock sim"), std::string::npos) << r.out;
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
                  " --clock wall --frames 3 --output y4m:/dev/null 2>&1");
    EXPECT_EQ(r.status, 2) << r.out;
    EXPECT_NE(r.out.find("gpio:nvs-no-such-chip:4"), std::string::npos) << r.out;
    r = sh(std::string(NVSTIM_EXE) + " run " + (dir_ / "tr.toml").string() +
           " --clock sim --frames 3 --stats " + (dir_ / "s.json").string() + " 2>&1");
    EXPECT_EQ(r.status, 0) << r.out;
    EXPECT_NE(r.out.find("trigger is not used with --clock sim"), std::string::npos) << r.out;
}

}  // namespace
}  // namespace nvs
