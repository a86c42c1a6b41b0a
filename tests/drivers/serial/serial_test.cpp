// NMEA and MAVLink framing against published references: the NMEA 0183 GGA example sentence
// with its checksum, the CRC-16/MCRF4XX check value, and MAVLink frames with CRC_EXTRA.
#include "drivers/serial/serial.h"

#include <gtest/gtest.h>

#include <cstring>

#include "drivers/serial/fake/fake_serial.h"

namespace nvs::drivers {
namespace {

int feed(NmeaParser& p, const std::string& s, NmeaSentence* last) {
    int n = 0;
    for (const char c : s)
        n += p.push(static_cast<std::uint8_t>(c), last) ? 1 : 0;
    return n;
}

TEST(Nmea, ParsesTheClassicGgaExample) {
    NmeaParser p;
    NmeaSentence s;
    ASSERT_EQ(feed(p, "$GPGGA,123519,4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,*47\r\n", &s),
              1);
    EXPECT_EQ(s.type, NmeaSentence::Type::Gga);
    EXPECT_NEAR(s.lat_deg, 48.0 + 7.038 / 60.0, 1e-12);
    EXPECT_NEAR(s.lon_deg, 11.0 + 31.0 / 60.0, 1e-12);
    EXPECT_NEAR(s.alt_m, 545.4 + 46.9, 1e-9);
    EXPECT_NEAR(s.timeOfDay_s, 12 * 3600 + 35 * 60 + 19, 1e-9);
}

TEST(Nmea, RmcHdtAndBadInputCounted) {
    NmeaParser p;
    NmeaSentence s;
    const std::string rmc =
        nmeaWithChecksum("$GPRMC,225446,A,4916.45,N,12311.12,W,000.5,054.7,191194,020.3,E");
    ASSERT_EQ(feed(p, rmc, &s), 1);
    EXPECT_NEAR(s.lon_deg, -(123.0 + 11.12 / 60.0), 1e-12);
    EXPECT_DOUBLE_EQ(s.utc_unix_s, 785285686.0);  // 1994-11-19T22:54:46Z
    ASSERT_EQ(feed(p, nmeaWithChecksum("$HEHDT,274.07,T"), &s), 1);
    EXPECT_DOUBLE_EQ(s.heading_deg, 274.07);
    // Bad checksum, garbage, truncated sentence, unsupported type: counted, never accepted.
    EXPECT_EQ(feed(p, "$GPHDT,274.07,T*00\r\n", &s), 0);
    EXPECT_EQ(feed(p, "\x01\xff garbage $GPGGA,12\r\n", &s), 0);
    EXPECT_EQ(feed(p, nmeaWithChecksum("$GPGSV,1,1,00"), &s), 0);
    EXPECT_EQ(p.counters().badChecksum, 1);
    EXPECT_EQ(p.counters().malformed, 1);
    EXPECT_EQ(p.counters().unsupported, 1);
    EXPECT_EQ(p.counters().sentences, 2);
}

TEST(Mavlink, CrcCheckValue) {
    const char* s = "123456789";
    EXPECT_EQ(mavlinkCrc(reinterpret_cast<const std::uint8_t*>(s), 9), 0x6F91);
}

TEST(Mavlink, V1AndV2FramesDecodeAndBadCrcIsCounted) {
    std::uint8_t att[28] = {};
    const std::uint32_t t = 1234;
    const float roll = 0.1f, pitch = -0.2f, yaw = 1.5f;
    std::memcpy(att, &t, 4);
    std::memcpy(att + 4, &roll, 4);
    std::memcpy(att + 8, &pitch, 4);
    std::memcpy(att + 12, &yaw, 4);
    std::uint8_t pos[28] = {};
    const std::int32_t lat = 473977420, lon = 85455940, alt = 488000;
    std::memcpy(pos + 4, &lat, 4);
    std::memcpy(pos + 8, &lon, 4);
    std::memcpy(pos + 12, &alt, 4);
    MavlinkParser p;
    MavlinkMessage m;
    int got = 0;
    for (int version : {1, 2}) {
        for (std::uint8_t b : mavlinkFrame(version, kMavlinkAttitude, att, 28)) {
            if (p.push(b, &m)) {
                MavlinkAttitude a;
                ASSERT_TRUE(decodeAttitude(m, &a));
                EXPECT_EQ(a.yaw_rad, yaw);
                EXPECT_EQ(a.pitch_rad, pitch);
                ++got;
            }
        }
        for (std::uint8_t b : mavlinkFrame(version, kMavlinkGlobalPositionInt, pos, 28)) {
            if (p.push(b, &m)) {
                MavlinkGlobalPosition g;
                ASSERT_TRUE(decodeGlobalPosition(m, &g));
                EXPECT_NEAR(g.lat_deg, 47.397742, 1e-9);
                EXPECT_NEAR(g.alt_m, 488.0, 1e-9);
                ++got;
            }
        }
    }
    EXPECT_EQ(got, 4);
    auto bad = mavlinkFrame(2, kMavlinkAttitude, att, 28);
    bad[12] ^= 0x40;  // corrupt one payload bit
    for (std::uint8_t b : bad)
        EXPECT_FALSE(p.push(b, &m));
    EXPECT_EQ(p.counters().badCrc, 1);
    // The parser resynchronises: the next good frame is accepted.
    int after = 0;
    for (std::uint8_t b : mavlinkFrame(1, kMavlinkAttitude, att, 28))
        after += p.push(b, &m) ? 1 : 0;
    EXPECT_EQ(after, 1);
}

TEST(FakeSerialPort, DisappearsAndComesBack) {
    FakeSerialPort port;
    ASSERT_EQ(port.open("/dev/ttyFAKE", 9600), 0);
    port.pushBytes("abc");
    port.pushError(EIO);
    std::uint8_t buf[8];
    EXPECT_EQ(port.read(buf, sizeof buf), 3);
    EXPECT_EQ(port.read(buf, sizeof buf), -EIO);
    EXPECT_EQ(port.state(), SerialState::Lost);
    EXPECT_EQ(port.open("/dev/ttyFAKE", 9600), 0);
    EXPECT_EQ(port.counters().lost, 1);
}

TEST(TermiosSerialPort, AbsentDeviceIsAnError) {
    TermiosSerialPort port;
    EXPECT_EQ(port.open("/dev/nvs-no-such-tty", 9600), -ENOENT);
    EXPECT_EQ(port.open("/dev/null", 12345), -EINVAL);
}

}  // namespace
}  // namespace nvs::drivers
