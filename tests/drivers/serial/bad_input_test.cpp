// Bad serial telemetry (docs/reliability-inputs.md): well-formed sentences and CRC-valid frames
// whose values lie outside the protocol's ranges are dropped and counted as out of range —
// a negative or overlong time of day, a date that does not exist, a NaN attitude.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "drivers/serial/serial.h"

namespace nvs::drivers {
namespace {

// Feeds a whole sentence (with checksum) and returns whether it was accepted.
bool feed(NmeaParser& p, const std::string& body, NmeaSentence* s) {
    bool ok = false;
    for (const char c : nmeaWithChecksum(body))
        ok = p.push(static_cast<std::uint8_t>(c), s) || ok;
    return ok;
}

TEST(NmeaBadInput, TimeOfDayMustBeAClockTime) {
    NmeaParser p;
    NmeaSentence s;
    const std::string tail = ",4807.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,";
    // A negative time of day was accepted (−1 s), and 1e300 was converted to int (UB).
    EXPECT_FALSE(feed(p, "$GPGGA,-00001" + tail, &s));
    EXPECT_FALSE(feed(p, "$GPGGA,1e300" + tail, &s));
    EXPECT_FALSE(feed(p, "$GPGGA,246000" + tail, &s));
    EXPECT_FALSE(feed(p, "$GPGGA,12:35:19" + tail, &s));
    EXPECT_EQ(p.counters().outOfRange, 1);  // 24:60:00
    EXPECT_EQ(p.counters().malformed, 3);
    ASSERT_TRUE(feed(p, "$GPGGA,235960.5" + tail, &s));  // a leap second
    EXPECT_DOUBLE_EQ(s.timeOfDay_s, 86400.5);
}

TEST(NmeaBadInput, DateMustExist) {
    NmeaParser p;
    NmeaSentence s;
    const auto rmc = [](const char* date) {
        return std::string("$GPRMC,123519,A,4807.038,N,01131.000,E,022.4,084.4,") + date +
               ",003.1,W";
    };
    // 31 February was accepted and normalised by timegm to 2 March.
    EXPECT_FALSE(feed(p, rmc("310200"), &s));
    EXPECT_FALSE(feed(p, rmc("290223"), &s));  // 2023 is not a leap year
    EXPECT_FALSE(feed(p, rmc("311124"), &s));  // 31 November
    EXPECT_FALSE(feed(p, rmc("001324"), &s));
    EXPECT_EQ(p.counters().outOfRange, 4);
    ASSERT_TRUE(feed(p, rmc("290224"), &s));
    // 2024-02-29T12:35:19Z
    EXPECT_DOUBLE_EQ(s.utc_unix_s, 1709210119.0);
}

TEST(NmeaBadInput, PositionAndHeadingRanges) {
    NmeaParser p;
    NmeaSentence s;
    EXPECT_FALSE(feed(p, "$GPGGA,123519,9107.038,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", &s));
    EXPECT_FALSE(feed(p, "$GPGGA,123519,4860.000,N,01131.000,E,1,08,0.9,545.4,M,46.9,M,,", &s));
    EXPECT_FALSE(feed(p, "$HEHDT,360.5,T", &s));
    EXPECT_FALSE(feed(p, "$HEHDT,nan,T", &s));
    EXPECT_EQ(p.counters().outOfRange, 3);
    EXPECT_EQ(p.counters().malformed, 1);
}

std::vector<std::uint8_t> attitude(float roll, float pitch, float yaw) {
    std::uint8_t att[28] = {};
    std::memcpy(att + 4, &roll, 4);
    std::memcpy(att + 8, &pitch, 4);
    std::memcpy(att + 12, &yaw, 4);
    return mavlinkFrame(2, kMavlinkAttitude, att, 28);
}

TEST(MavlinkBadInput, NonFiniteOrOutOfRangeAttitudeIsDropped) {
    MavlinkParser p;
    MavlinkMessage m;
    const float nan = std::numeric_limits<float>::quiet_NaN();
    const float inf = std::numeric_limits<float>::infinity();
    int accepted = 0;
    for (const auto& frame : {attitude(nan, 0, 0), attitude(0, inf, 0), attitude(0, 0, 3.2f),
                              attitude(0.1f, -0.2f, 3.14159265f)}) {
        for (const std::uint8_t b : frame)
            accepted += p.push(b, &m) ? 1 : 0;
    }
    EXPECT_EQ(accepted, 1);  // only the last: float(π) is in range
    EXPECT_EQ(p.counters().outOfRange, 3);
    EXPECT_EQ(p.counters().badCrc, 0);  // the CRCs were right
}

TEST(MavlinkBadInput, PositionOutOfRangeIsDropped) {
    std::uint8_t pos[28] = {};
    const std::int32_t lat = 910000000;  // 91°
    std::memcpy(pos + 4, &lat, 4);
    MavlinkParser p;
    MavlinkMessage m;
    for (const std::uint8_t b : mavlinkFrame(1, kMavlinkGlobalPositionInt, pos, 28))
        EXPECT_FALSE(p.push(b, &m));
    EXPECT_EQ(p.counters().outOfRange, 1);
}

}  // namespace
}  // namespace nvs::drivers
