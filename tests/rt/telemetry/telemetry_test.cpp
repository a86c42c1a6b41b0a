// Pose track: interpolation and extrapolation of a straight-line motion are exact; staleness;
// a serial source that disappears holds the last good state and comes back.
#include <gtest/gtest.h>
#include <pty.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "drivers/can/fake/fake_can.h"
#include "drivers/serial/fake/fake_serial.h"
#include "rt/clock/clock.h"
#include "rt/telemetry/sources.h"
#include "sim/core/units.h"

namespace nvs::rt {
namespace {

TelemetryUpdate yawAt(double t, double yaw_deg) {
    TelemetryUpdate u;
    u.rx_s = t;
    u.fields = TelemetryUpdate::kYaw;
    u.yaw_rad = yaw_deg * kRadPerDeg;
    return u;
}

TEST(PlatformTrack, InterpolatesExtrapolatesAndFlagsStale) {
    PlatformTrack track(PlatformState{}, 0.5, 0.1);
    PlatformState s;
    track.sample(0.0, s);
    EXPECT_TRUE(s.stale);  // nothing received yet
    EXPECT_FALSE(s.poseFromTelemetry);
    track.apply(yawAt(0.0, 350.0));
    track.apply(yawAt(0.1, 10.0));  // through north: +20° in 0.1 s, not −340°
    track.sample(0.05, s);
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 0.0, 1e-9);
    track.sample(0.15, s);  // 0.05 s ahead: 20°
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 20.0, 1e-9);
    track.sample(1.0, s);  // extrapolation capped at 0.1 s: 30°, and stale after 0.5 s
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 30.0, 1e-9);
    EXPECT_TRUE(s.stale);
    EXPECT_DOUBLE_EQ(s.telemetryRx_s, 0.1);
}

// A scenario whose [platform] states a pose: the pose is rendered before telemetry arrives,
// and telemetry's attitude replaces its attitude.
TEST(PlatformTrack, AStatedScenarioPoseIsHeldUntilTelemetryGivesOne) {
    PlatformState stated;
    stated.yaw_rad = 240.0 * kRadPerDeg;
    stated.poseFromTelemetry = true;
    PlatformTrack track(stated, 0.5, 0.1);
    PlatformState s;
    track.sample(0.0, s);
    EXPECT_TRUE(s.poseFromTelemetry);
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 240.0, 1e-9);
    track.apply(yawAt(0.0, 10.0));
    track.sample(0.0, s);
    EXPECT_TRUE(s.poseFromTelemetry);
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 10.0, 1e-9);
}

TEST(SerialInput, DisappearingDeviceAndBadChecksumsAreCountedNotFatal) {
    auto port = std::make_unique<drivers::FakeSerialPort>();
    drivers::FakeSerialPort* fake = port.get();
    auto input = std::make_unique<SerialInput>(std::move(port), "/dev/ttyFAKE", 9600,
                                               SerialInput::Proto::Nmea);
    TelemetryPlatform platform(std::move(input), PlatformState{}, 0.5, 0.1, false);
    fake->pushBytes(drivers::nmeaWithChecksum("$HEHDT,90.0,T"));
    fake->pushBytes("$HEHDT,91.0,T*00\r\n");  // bad checksum
    fake->pushError(EIO);                     // unplugged
    PlatformState s;
    platform.sample(0.0, 0.0, s);
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 90.0, 1e-9);
    platform.sample(0.5, 0.5, s);  // lost: last good state held
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 90.0, 1e-9);
    fake->pushBytes(drivers::nmeaWithChecksum("$HEHDT,95.0,T"));
    platform.sample(2.0, 2.0, s);  // reopened after a second
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 95.0, 1e-9);
    EXPECT_FALSE(platform.failed());
    const std::string st = platform.status();
    EXPECT_NE(st.find("bad checksum 1"), std::string::npos) << st;
    EXPECT_NE(st.find("disconnects 1"), std::string::npos) << st;
    EXPECT_EQ(fake->opens, 2);
}

TEST(TelemetryPlatform, BadInputStopsWhenConfigured) {
    auto port = std::make_unique<drivers::FakeSerialPort>();
    drivers::FakeSerialPort* fake = port.get();
    TelemetryPlatform platform(std::make_unique<SerialInput>(std::move(port), "/dev/ttyFAKE", 9600,
                                                             SerialInput::Proto::Mavlink),
                               PlatformState{}, 0.5, 0.1, true);
    std::uint8_t att[28] = {};
    auto frame = drivers::mavlinkFrame(2, drivers::kMavlinkAttitude, att, 28);
    frame[frame.size() - 1] ^= 1;  // bad CRC
    fake->pushBytes(frame.data(), frame.size());
    PlatformState s;
    platform.sample(0.0, 0.0, s);
    EXPECT_TRUE(platform.failed());
}

}  // namespace
}  // namespace nvs::rt

namespace nvs::rt {
namespace {

// `can:IFACE?record=FILE`: every frame received is written as a candump line; the log
// reproduces the frames exactly and, replayed, drives the platform to the same decoded state.
TEST(CanRecord, RecordedLogReplaysToTheSameDecodedState) {
    const std::string dbcPath = std::string(NVS_SOURCE_DIR) + "/config/can/nvstim.dbc";
    const auto db = drivers::DbcDatabase::load(dbcPath);
    const drivers::DbcMessage* att = db.findByName("NVS_ATTITUDE");
    const drivers::DbcMessage* pos = db.findByName("NVS_POSITION");
    const drivers::DbcMessage* cam = db.findByName("NVS_CAMERA");
    const drivers::DbcMessage* fd = db.findByName("NVS_POSE_FD");
    ASSERT_TRUE(att && pos && cam && fd);
    const auto encode = [](const drivers::DbcMessage* m, std::initializer_list<double> values) {
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
    };
    // A turning, climbing flight; its last three samples repeat so that the pose after the
    // log is the same however far the two runs sample past it (extrapolation of a still pose).
    std::vector<drivers::CanFrame> sent;
    for (int i = 0; i < 20; ++i) {
        const int k = std::min(i, 17);
        sent.push_back(encode(att, {1.5, -2.0 + 0.1 * k, 30.0 + 2.0 * k}));
        sent.push_back(encode(pos, {47.1 + 1e-4 * k, 8.5 - 2e-4 * k}));
        if (i % 5 == 0) sent.push_back(encode(cam, {4.5 + 0.5 * (k / 5), 2e-3, 1, 0}));
    }
    sent.push_back(encode(fd, {47.2, 8.4, 1234.5, 0.5, 1.0, 2.0}));  // 29-bit CAN FD
    sent.push_back(encode(att, {1.5, -0.3, 64.0}));
    sent.push_back(encode(att, {1.5, -0.3, 64.0}));
    drivers::CanFrame unknown;
    unknown.id = 0x7ff;
    unknown.len = 2;
    sent.push_back(unknown);  // counted as unknown, recorded all the same

    const std::string log = ::testing::TempDir() + "nvs_can_record.log";
    auto bus = std::make_unique<drivers::FakeCanBus>();
    const double realNow_s = static_cast<double>(realtimeNow_ns()) * 1e-9;
    for (std::size_t i = 0; i < sent.size(); ++i)
        bus->push(sent[i], std::floor(realNow_s) - 2.0 + 0.01 * static_cast<double>(i));
    PlatformState live;
    {
        TelemetryPlatform platform(
            std::make_unique<CanInput>(std::move(bus), "vcan0", true, db, log), PlatformState{},
            100.0, 0.1, false);
        platform.sample(50.0, 50.0, live);  // reads everything, records it
        EXPECT_NE(platform.status().find("unknown id 1"), std::string::npos) << platform.status();
    }
    // The log holds every frame, bit for bit, at the kernel receive time to the microsecond.
    std::ifstream in(log);
    std::string line;
    std::size_t n = 0;
    while (std::getline(in, line)) {
        double t_s = 0.0;
        drivers::CanFrame f;
        ASSERT_TRUE(drivers::parseCandumpLine(line, &t_s, &f)) << line;
        ASSERT_LT(n, sent.size());
        const drivers::CanFrame& s = sent[n];
        EXPECT_EQ(f.id, s.id) << line;
        EXPECT_EQ(f.extended, s.extended) << line;
        EXPECT_EQ(f.fd, s.fd) << line;
        ASSERT_EQ(f.len, s.len) << line;
        EXPECT_EQ(0, std::memcmp(f.data, s.data, f.len)) << line;
        EXPECT_NEAR(t_s, std::floor(realNow_s) - 2.0 + 0.01 * static_cast<double>(n), 1e-6);
        ++n;
    }
    EXPECT_EQ(n, sent.size());
    // Replayed, the log gives the same state (the log's first frame is at run time 0).
    TelemetryPlatform replay(std::make_unique<ReplayInput>(log, db), PlatformState{}, 100.0, 0.1,
                             false);
    PlatformState again;
    replay.sample(5.0, 5.0, again);
    EXPECT_TRUE(live.poseFromTelemetry);
    EXPECT_TRUE(again.poseFromTelemetry);
    EXPECT_DOUBLE_EQ(again.lat_deg, live.lat_deg);
    EXPECT_DOUBLE_EQ(again.lon_deg, live.lon_deg);
    EXPECT_DOUBLE_EQ(again.alt_m, live.alt_m);
    EXPECT_DOUBLE_EQ(again.yaw_rad, live.yaw_rad);
    EXPECT_DOUBLE_EQ(again.pitch_rad, live.pitch_rad);
    EXPECT_DOUBLE_EQ(again.roll_rad, live.roll_rad);
    EXPECT_DOUBLE_EQ(again.gain_V, live.gain_V);
    EXPECT_DOUBLE_EQ(again.gate_s, live.gate_s);
    EXPECT_EQ(again.gateMode, live.gateMode);
    EXPECT_NEAR(live.yaw_rad, 64.0 * kRadPerDeg, 0.01 * kRadPerDeg);  // the still final pose
    EXPECT_NEAR(live.gain_V, 6.0, 0.05);
    std::remove(log.c_str());
}

// A serial hang-up (a USB adapter unplugged) on a real tty: a pseudo-terminal whose master is
// closed hangs the slave up (pty_close → tty_vhangup), as usb_serial_disconnect does. It must be
// detected and counted, the last good state held, and the port reopened with backoff when the
// device is back (here a new pty behind the same path, as a udev by-id link would be). Before:
// read() returned 0 — "no data" — forever, and the port was never reopened.
TEST(SerialInput, AHangUpIsDetectedCountedAndThePortReopened) {
    namespace fs = std::filesystem;
    std::string tmpl = (fs::temp_directory_path() / "nvs_pty-XXXXXX").string();
    ASSERT_NE(::mkdtemp(tmpl.data()), nullptr);
    const fs::path link = fs::path(tmpl) / "ttyGPS";
    int master = -1, slave = -1;
    ASSERT_EQ(::openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
    fs::create_symlink(::ttyname(slave), link);
    ::close(slave);
    TelemetryPlatform platform(
        std::make_unique<SerialInput>(std::make_unique<drivers::TermiosSerialPort>(), link.string(),
                                      9600, SerialInput::Proto::Nmea),
        PlatformState{}, 0.5, 0.1, false);
    const auto send = [](int fd, const std::string& s) {
        ASSERT_EQ(::write(fd, s.data(), s.size()), static_cast<ssize_t>(s.size()));
    };
    send(master, drivers::nmeaWithChecksum("$HEHDT,90.0,T"));
    PlatformState s;
    for (int i = 0; i < 50 && !s.poseFromTelemetry; ++i) {  // the pty delivers within a tick
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        platform.sample(0.0, 0.0, s);
    }
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 90.0, 1e-9);
    ::close(master);               // unplugged
    platform.sample(0.1, 0.1, s);  // the hang-up is read
    platform.sample(0.15, 0.15, s);
    std::string st = platform.status();
    EXPECT_NE(st.find("disconnects 1, hang-ups 1"), std::string::npos) << st;
    EXPECT_NE(st.find("PORT LOST"), std::string::npos) << st;
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 90.0, 1e-9);  // last good state held
    platform.sample(0.3, 0.3, s);  // first retry (0.1 s after the loss): the device is gone
    st = platform.status();
    EXPECT_NE(st.find("reopen attempts 1, reopened 0"), std::string::npos) << st;
    // Plugged back in: a new device behind the same path.
    ASSERT_EQ(::openpty(&master, &slave, nullptr, nullptr, nullptr), 0);
    fs::remove(link);
    fs::create_symlink(::ttyname(slave), link);
    platform.sample(0.35, 0.35, s);  // backoff: the next retry is 0.2 s after the first
    EXPECT_NE(platform.status().find("reopen attempts 1,"), std::string::npos);
    platform.sample(0.6, 0.6, s);  // reopened
    ::close(slave);
    send(master, drivers::nmeaWithChecksum("$HEHDT,95.0,T"));
    for (int i = 0; i < 50 && std::fabs(s.yaw_rad * kDegPerRad - 95.0) > 1e-6; ++i) {
        std::this_thread::sleep_for(std::chrono::milliseconds(2));
        platform.sample(0.7, 0.7, s);
    }
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 95.0, 1e-9);
    st = platform.status();
    EXPECT_NE(st.find("reopen attempts 2, reopened 1"), std::string::npos) << st;
    EXPECT_EQ(st.find("PORT LOST"), std::string::npos) << st;
    ::close(master);
    fs::remove_all(tmpl);
}

// A CAN interface that goes down (ENETDOWN) is counted, the last state held, and the socket
// reopened with backoff: 0.1 s, then doubling while it stays down.
TEST(CanInput, AnInterfaceThatGoesDownIsReopenedWithBackoff) {
    const auto db =
        drivers::DbcDatabase::load(std::string(NVS_SOURCE_DIR) + "/config/can/nvstim.dbc");
    const drivers::DbcMessage* att = db.findByName("NVS_ATTITUDE");
    ASSERT_NE(att, nullptr);
    const auto yawFrame = [&](double yaw_deg) {
        drivers::CanFrame f;
        f.id = att->id;
        f.len = static_cast<std::uint8_t>(att->size);
        for (const auto& sig : att->signals)
            drivers::encodeSignal(sig, sig.name == "Yaw_deg" ? yaw_deg : 0.0, f.data, f.len);
        return f;
    };
    auto owned = std::make_unique<drivers::FakeCanBus>();
    drivers::FakeCanBus& bus = *owned;
    // No extrapolation: a frame's run-clock receive time is the sample's now less the frame's
    // real age, so under load (a few ms between the push and the sample) the 40° frame would
    // land just before 0.75 s and the 30° → 40° rate would carry the state past 40°.
    TelemetryPlatform platform(std::make_unique<CanInput>(std::move(owned), "can0", false, db, ""),
                               PlatformState{}, 100.0, 0.0, false);
    const double now_s = static_cast<double>(realtimeNow_ns()) * 1e-9;
    bus.push(yawFrame(30.0), now_s);
    bus.pushError(ENETDOWN);
    PlatformState s;
    platform.sample(0.0, 0.0, s);
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 30.0, 0.01);
    bus.openError = ENODEV;  // still down
    for (const double t : {0.01, 0.05, 0.12, 0.2, 0.3, 0.33, 0.5, 0.7})
        platform.sample(t, t, s);
    // Lost at 0.01; retries at 0.12 (+0.1), 0.33 (+0.2) and 0.73 (+0.4) would be due: two by 0.7.
    std::string st = platform.status();
    EXPECT_NE(st.find("bus lost 1, reopen attempts 2, reopened 0, BUS LOST"), std::string::npos)
        << st;
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 30.0, 0.01);
    bus.openError = 0;  // up again
    bus.push(yawFrame(40.0), static_cast<double>(realtimeNow_ns()) * 1e-9);
    platform.sample(0.72, 0.72, s);  // not yet due
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 30.0, 0.01);
    platform.sample(0.75, 0.75, s);
    EXPECT_NEAR(s.yaw_rad * kDegPerRad, 40.0, 0.01);
    st = platform.status();
    EXPECT_NE(st.find("bus lost 1, reopen attempts 3, reopened 1"), std::string::npos) << st;
    EXPECT_EQ(st.find("BUS LOST"), std::string::npos) << st;
}

}  // namespace
}  // namespace nvs::rt
