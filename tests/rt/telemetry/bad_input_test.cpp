// Telemetry checked at the boundary (docs/reliability-inputs.md): a NaN attitude with a valid
// CRC, a DBC-decoded value outside its [min|max] or not finite, and an update outside the
// track's ranges are counted and leave the last good state in place; a replay log that is not
// a regular file is a setup error, not a hang.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <memory>
#include <string>
#include <vector>

#include "drivers/serial/fake/fake_serial.h"
#include "rt/telemetry/sources.h"
#include "sim/core/error.h"
#include "sim/core/units.h"

namespace nvs::rt {
namespace {

constexpr double kNaN = std::numeric_limits<double>::quiet_NaN();

TEST(TrackBoundary, UpdatesOutsideTheRangesAreRejectedAndCounted) {
    PlatformTrack track(PlatformState{}, 0.5, 0.1);
    TelemetryUpdate good;
    good.rx_s = 0.0;
    good.fields = TelemetryUpdate::kLatLon | TelemetryUpdate::kRollPitch;
    good.lat_deg = 43.0;
    good.lon_deg = -77.0;
    good.roll_rad = 0.1;
    EXPECT_TRUE(track.apply(good));
    std::vector<TelemetryUpdate> bad(5, good);
    for (TelemetryUpdate& u : bad)
        u.rx_s = 0.05;
    bad[0].lat_deg = kNaN;
    bad[1].lat_deg = 91.0;
    bad[2].roll_rad = std::numeric_limits<double>::infinity();
    bad[3].fields |= TelemetryUpdate::kGain;
    bad[3].gain_V = -1.0;
    bad[4].rx_s = kNaN;
    for (const TelemetryUpdate& u : bad)
        EXPECT_FALSE(track.apply(u));
    EXPECT_EQ(track.rejected(), 5);
    EXPECT_EQ(track.updates(), 1);
    PlatformState s;
    track.sample(0.05, s);  // the last good state
    EXPECT_DOUBLE_EQ(s.lat_deg, 43.0);
    EXPECT_DOUBLE_EQ(s.roll_rad, 0.1);
}

TEST(TrackBoundary, ExtrapolationStopsAtThePole) {
    // Found by the candump and nmea fuzz targets: two fixes approaching the pole extrapolated
    // to a latitude beyond 90°.
    PlatformTrack track(PlatformState{}, 0.5, 0.1);
    TelemetryUpdate u;
    u.fields = TelemetryUpdate::kLatLon;
    u.rx_s = 0.0;
    u.lat_deg = 89.0;
    track.apply(u);
    u.rx_s = 0.01;
    u.lat_deg = 90.0;
    track.apply(u);
    PlatformState s;
    track.sample(0.1, s);  // 0.09 s ahead at 100°/s
    EXPECT_EQ(s.lat_deg, 90.0);
}

// A CRC-valid MAVLink ATTITUDE with these angles.
std::vector<std::uint8_t> attitude(float roll, float pitch, float yaw) {
    std::uint8_t att[28] = {};
    std::memcpy(att + 4, &roll, 4);
    std::memcpy(att + 8, &pitch, 4);
    std::memcpy(att + 12, &yaw, 4);
    return drivers::mavlinkFrame(2, drivers::kMavlinkAttitude, att, 28);
}

TEST(SerialBoundary, NanAttitudeHoldsTheLastGoodState) {
    // One NaN attitude with a valid CRC went into the platform state and aborted the process
    // inside Embree (rtcIntersect16) at the next frame.
    for (const bool fatal : {false, true}) {
        auto port = std::make_unique<drivers::FakeSerialPort>();
        drivers::FakeSerialPort* fake = port.get();
        TelemetryPlatform platform(
            std::make_unique<SerialInput>(std::move(port), "/dev/ttyFAKE", 57600,
                                          SerialInput::Proto::Mavlink),
            PlatformState{}, 0.5, 0.1, fatal);
        const auto good = attitude(0.1f, -0.2f, 1.5f);
        fake->pushBytes(good.data(), good.size());
        PlatformState s;
        platform.sample(0.0, 0.0, s);
        EXPECT_FLOAT_EQ(static_cast<float>(s.roll_rad), 0.1f);
        const auto bad = attitude(std::numeric_limits<float>::quiet_NaN(), 0.0f, 0.0f);
        fake->pushBytes(bad.data(), bad.size());
        platform.sample(0.1, 0.1, s);
        EXPECT_TRUE(std::isfinite(s.roll_rad) && std::isfinite(s.pitch_rad) &&
                    std::isfinite(s.yaw_rad));
        EXPECT_FLOAT_EQ(static_cast<float>(s.roll_rad), 0.1f);
        EXPECT_NE(platform.status().find("out of range 1"), std::string::npos) << platform.status();
        EXPECT_EQ(platform.failed(), fatal);  // bad_input = "stop" stops on it
    }
}

TEST(CanBoundary, DbcRangeAndNonFiniteValuesRejectTheFrame) {
    // Pitch_deg is declared [-90|90]; Roll_deg here has a factor that overflows to infinity.
    const auto db = drivers::DbcDatabase::parse(
        "BO_ 272 ATT: 6 NAV\n"
        " SG_ Roll_deg : 0|16@1- (0.01,0) [-180|180] \"deg\" X\n"
        " SG_ Pitch_deg : 16|16@1- (0.01,0) [-90|90] \"deg\" X\n"
        "BO_ 273 BAD: 2 NAV\n"
        " SG_ Yaw_deg : 0|16@1- (1e306,0) [0|0] \"deg\" X\n",
        "t.dbc");
    CanDecoder dec(db);
    PlatformTrack track(PlatformState{}, 0.5, 0.1);
    const auto frame = [&](std::uint32_t id, double a, double b) {
        drivers::CanFrame f;
        const drivers::DbcMessage* m = db.find(id, false);
        f.id = id;
        f.len = static_cast<std::uint8_t>(m->size);
        drivers::encodeSignal(m->signals[0], a, f.data, f.len);
        if (m->signals.size() > 1) drivers::encodeSignal(m->signals[1], b, f.data, f.len);
        return f;
    };
    TelemetryUpdate u;
    ASSERT_TRUE(dec.decode(frame(272, 10.0, 20.0), 0.0, &u));
    track.apply(u);
    EXPECT_FALSE(dec.decode(frame(272, 11.0, 120.0), 0.1, &u));  // pitch 120° > 90°
    drivers::CanFrame inf = frame(273, 0.0, 0.0);
    inf.data[0] = 200;  // 200 · 1e306 = 2e308, beyond DBL_MAX: inf
    EXPECT_FALSE(dec.decode(inf, 0.2, &u));
    EXPECT_EQ(dec.counters().outOfRange, 2);
    PlatformState s;
    track.sample(0.2, s);
    EXPECT_NEAR(s.roll_rad * kDegPerRad, 10.0, 1e-9);  // the whole frame was held back
    EXPECT_NEAR(s.pitch_rad * kDegPerRad, 20.0, 1e-9);
}

TEST(ReplayBoundary, LogThatIsNotARegularFileIsASetupError) {
    const auto db =
        drivers::DbcDatabase::load(std::string(NVS_SOURCE_DIR) + "/config/can/nvstim.dbc");
    EXPECT_THROW(ReplayInput("/dev/zero", db), SetupError);  // read forever before
    const std::string fifo = ::testing::TempDir() + "nvs_replay_fifo";
    ::unlink(fifo.c_str());
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    try {
        ReplayInput in(fifo, db);  // opened with no writer: blocked forever before
        FAIL();
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("FIFO"), std::string::npos) << e.what();
    }
    ::unlink(fifo.c_str());
}

}  // namespace
}  // namespace nvs::rt
