// CAN telemetry under the sim clock: the loop steps with the telemetry's own time signal.
// A log whose time marks precede the messages they time gives, frame by frame, exactly the
// platform states that `replay:` of the same log gives, however early the frames arrive; the
// input waits for a mark past the loop's "now", ends the stream after a silence, and stops
// waiting on the stop flag.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <string>
#include <vector>

#include "drivers/can/fake/fake_can.h"
#include "rt/telemetry/sources.h"
#include "sim/core/error.h"
#include "sim/core/units.h"

namespace nvs::rt {
namespace {

struct Timed {
    long long sec;
    long usec;
    drivers::CanFrame frame;
};

drivers::CanFrame encode(const drivers::DbcMessage* m, std::initializer_list<double> values) {
    drivers::CanFrame f;
    f.id = m->id;
    f.extended = m->extended;
    f.fd = m->size > 8;
    f.len = static_cast<std::uint8_t>(m->size);
    auto v = values.begin();
    for (const auto& s : m->signals) {
        if (v == values.end()) break;
        drivers::encodeSignal(s, *v++, f.data, f.len);
    }
    return f;
}

// A manoeuvre at 100 Hz, each group a time mark (NVS_TIME) followed by attitude and position.
// Yaw and latitude are quadratic in time, so a pose sampled with messages from after the loop's
// "now" (interpolated) differs from one extrapolated from the messages up to it.
std::vector<Timed> manoeuvre(const drivers::DbcDatabase& db, int groups) {
    const drivers::DbcMessage* tm = db.findByName("NVS_TIME");
    const drivers::DbcMessage* att = db.findByName("NVS_ATTITUDE");
    const drivers::DbcMessage* pos = db.findByName("NVS_POSITION");
    std::vector<Timed> out;
    const long long sec0 = 946684800;  // 2000-01-01T00:00:00Z
    for (int j = 0; j < groups; ++j) {
        const long us = 10000L * j;  // some marks fall on a 30-Hz tick: equal times decide alike
        const long long sec = sec0 + us / 1000000;
        const long usec = us % 1000000;
        const double t = static_cast<double>(us) * 1e-6;
        out.push_back(
            {sec, usec, encode(tm, {static_cast<double>(sec), static_cast<double>(usec) * 1e-6})});
        out.push_back({sec, usec, encode(att, {0.5 * t, -10.0 + t, 20.0 + 90.0 * t * t})});
        out.push_back({sec, usec, encode(pos, {43.0 + 1e-3 * t * t, -77.0 + 1e-4 * t})});
    }
    return out;
}

std::string writeLog(const std::vector<Timed>& frames, const std::string& name) {
    const std::string path = ::testing::TempDir() + name;
    std::ofstream out(path);
    for (const Timed& f : frames) {
        char line[256];
        const double t = static_cast<double>(f.sec) + static_cast<double>(f.usec) * 1e-6;
        const std::size_t n = drivers::formatCandumpLine(t, "vcan0", f.frame, line, sizeof line);
        out.write(line, static_cast<std::streamsize>(n));
    }
    return path;
}

drivers::DbcDatabase shippedDbc() {
    return drivers::DbcDatabase::load(std::string(NVS_SOURCE_DIR) + "/config/can/nvstim.dbc");
}

CanLockstep lockstep(double idle_s, const std::atomic<bool>* stop = nullptr) {
    CanLockstep l;
    l.enabled = true;
    l.idle_s = idle_s;
    l.stop = stop;
    return l;
}

double secondsSince(std::chrono::steady_clock::time_point t0) {
    return std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
}

TEST(CanLockstep, GivesTheStatesOfTheReplayedLogFrameByFrame) {
    const auto db = shippedDbc();
    const std::vector<Timed> frames = manoeuvre(db, 120);  // 1.2 s
    const std::string log = writeLog(frames, "nvs_lockstep.log");
    TelemetryPlatform replay(std::make_unique<ReplayInput>(log, db), PlatformState{}, 0.5, 0.1,
                             false);
    // Every frame is on the bus before the first is sampled: the input must hold back what the
    // loop has not reached yet (received "too early" is the extreme of arrival jitter).
    auto bus = std::make_unique<drivers::FakeCanBus>();
    for (const Timed& f : frames)
        bus->push(f.frame, 1.0);
    auto can = std::make_unique<CanInput>(std::move(bus), "vcan0", false, db, "", lockstep(0.05));
    const drivers::CanBus* busView = &can->bus();
    TelemetryPlatform live(std::move(can), PlatformState{}, 0.5, 0.1, false);
    // The sim clock's calls (rt/loop): frame r samples t_r = r/30 with now = t_{r−1} (0 for r = 0).
    int differsFromInterpolation = 0;
    for (int r = 0; r < 36; ++r) {
        const double t = r / 30.0;
        const double now = r > 0 ? (r - 1) / 30.0 : 0.0;
        PlatformState a, b;
        replay.sample(t, now, a);
        live.sample(t, now, b);
        ASSERT_EQ(a.yaw_rad, b.yaw_rad) << "frame " << r;
        ASSERT_EQ(a.pitch_rad, b.pitch_rad) << "frame " << r;
        ASSERT_EQ(a.roll_rad, b.roll_rad) << "frame " << r;
        ASSERT_EQ(a.lat_deg, b.lat_deg) << "frame " << r;
        ASSERT_EQ(a.lon_deg, b.lon_deg) << "frame " << r;
        ASSERT_EQ(a.utc_unix_s, b.utc_unix_s) << "frame " << r;
        ASSERT_EQ(a.stale, b.stale) << "frame " << r;
        ASSERT_EQ(a.telemetryRx_s, b.telemetryRx_s) << "frame " << r;
        // Messages read = the three of every group up to now, plus the held mark after it.
        long groups = 0;
        for (std::size_t i = 0; i < frames.size(); i += 3) {
            const auto utc = [&](std::size_t k) {
                return static_cast<double>(frames[k].sec) +
                       static_cast<double>(frames[k].usec) * 1e-6;
            };
            if (utc(i) - utc(0) <= now) ++groups;
        }
        ASSERT_EQ(busView->counters().frames, 3 * groups + 1) << "frame " << r;
        // The pose is the one from messages up to now, not the one between the samples around t
        // (yaw 20 + 90·t² degrees): the comparison above could tell the two apart.
        const double interpolated_deg = 20.0 + 90.0 * t * t;
        if (std::fabs(b.yaw_rad * kDegPerRad - interpolated_deg) > 0.02) ++differsFromInterpolation;
    }
    EXPECT_GT(differsFromInterpolation, 10);
    EXPECT_NE(live.status().find("lockstep: time marks"), std::string::npos) << live.status();
    std::remove(log.c_str());
}

TEST(CanLockstep, WaitsForATimeMarkPastNowThenEndsTheStreamAfterSilence) {
    const auto db = shippedDbc();
    const std::vector<Timed> frames = manoeuvre(db, 4);
    auto bus = std::make_unique<drivers::FakeCanBus>();
    for (int i = 0; i < 3; ++i)  // group 0 only: no mark past now = 0.02 yet
        bus->push(frames[static_cast<std::size_t>(i)].frame, 1.0);
    drivers::FakeCanBus* fake = bus.get();
    TelemetryPlatform live(
        std::make_unique<CanInput>(std::move(bus), "vcan0", false, db, "", lockstep(0.2)),
        PlatformState{}, 0.5, 0.1, false);
    PlatformState s;
    auto t0 = std::chrono::steady_clock::now();
    live.sample(0.03, 0.02, s);
    EXPECT_GE(secondsSince(t0), 0.2);  // waited the whole silence
    EXPECT_NE(live.status().find("stream ended"), std::string::npos) << live.status();
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 20.0, 0.01);
    // After the end, frames that still come are applied, and nothing waits.
    for (std::size_t i = 3; i < frames.size(); ++i)
        fake->push(frames[i].frame, 1.0);
    t0 = std::chrono::steady_clock::now();
    live.sample(0.05, 0.04, s);
    EXPECT_LT(secondsSince(t0), 0.1);
    // Groups at 0.01, 0.02, 0.03 s applied (≤ now); yaw at 0.05 s extrapolated from the last two.
    const auto yaw = [](double t) { return 20.0 + 90.0 * t * t; };
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, yaw(0.03) + 2.0 * (yaw(0.03) - yaw(0.02)), 0.02);
}

TEST(CanLockstep, StopFlagEndsTheWait) {
    const auto db = shippedDbc();
    std::atomic<bool> stop{true};
    TelemetryPlatform live(
        std::make_unique<CanInput>(std::make_unique<drivers::FakeCanBus>(), "vcan0", false, db, "",
                                   lockstep(30.0, &stop)),
        PlatformState{}, 0.5, 0.1, false);
    PlatformState s;
    const auto t0 = std::chrono::steady_clock::now();
    live.sample(0.0, 0.0, s);
    EXPECT_LT(secondsSince(t0), 1.0);
    EXPECT_TRUE(s.stale);
}

TEST(CanLockstep, NeedsATimeSignalInTheDbc) {
    const auto db = drivers::DbcDatabase::parse(
        "BO_ 272 ATT: 2 NAV\n SG_ Yaw_deg : 0|16@1+ (0.01,0) [0|360] \"deg\" STIM\n", "t.dbc");
    try {
        CanInput in(std::make_unique<drivers::FakeCanBus>(), "vcan0", false, db, "", lockstep(1.0));
        FAIL() << "a DBC without UnixTime_s was accepted";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("UnixTime_s"), std::string::npos) << e.what();
    }
    // Without lockstep (the wall clock) the same DBC is fine.
    CanInput wall(std::make_unique<drivers::FakeCanBus>(), "vcan0", false, db, "");
    EXPECT_EQ(wall.badInput(), 0);
}

}  // namespace
}  // namespace nvs::rt
