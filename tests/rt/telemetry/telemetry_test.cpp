// Pose track: interpolation and extrapolation of a straight-line motion are exact; staleness;
// a serial source that disappears holds the last good state and comes back.
#include <gtest/gtest.h>

#include <cmath>

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
