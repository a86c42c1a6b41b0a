// Bad DBC and candump input (docs/reliability-inputs.md): a DBC line of 40 KB is parsed
// without recursion, a longer one than the limit names its line, numbers too large for their
// field are errors with file:line (not std::out_of_range), decoded values outside a signal's
// declared [min|max] are recognised, and candump times are bounded.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <limits>
#include <string>

#include "drivers/can/can.h"
#include "sim/core/error.h"

namespace nvs::drivers {
namespace {

std::string errorOf(const std::string& dbc) {
    try {
        DbcDatabase::parse(dbc, "t.dbc");
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

TEST(DbcBadInput, FortyKilobyteLineParsesWithoutRecursion) {
    // std::regex_match recursed once per character of this line and overflowed the stack.
    std::string receivers;
    while (receivers.size() < 40000)
        receivers += "NODE_" + std::to_string(receivers.size()) + ",";
    receivers.pop_back();
    const std::string dbc =
        "BO_ 256 P: 8 NAV\n SG_ Latitude_deg : 0|32@1- (1E-07,0) [-90|90] \"deg\" " + receivers +
        "\n";
    ASSERT_GT(dbc.size(), 40000u);
    const DbcDatabase db = DbcDatabase::parse(dbc, "long.dbc");
    ASSERT_NE(db.find(256, false), nullptr);
    EXPECT_EQ(db.find(256, false)->signals.at(0).max, 90.0);
    // A garbage line of the same length is an error, also without recursion.
    EXPECT_NE(errorOf("BO_ 1 A: 8 X\n SG_ " + std::string(40000, '(') + "\n").find("t.dbc:2"),
              std::string::npos);
}

TEST(DbcBadInput, LineLongerThanTheLimitNamesItsLine) {
    const std::string e =
        errorOf("VERSION \"\"\nCM_ \"" + std::string(kDbcMaxLineBytes, 'x') + "\";\n");
    EXPECT_NE(e.find("t.dbc:2"), std::string::npos) << e;
    EXPECT_NE(e.find("65536"), std::string::npos) << e;
}

TEST(DbcBadInput, OversizedNumbersAreErrorsWithTheirLine) {
    // std::stoull / std::stoi threw std::out_of_range here (exit 1, no file:line).
    EXPECT_NE(errorOf("BO_ 99999999999999999999 A: 8 X\n").find("t.dbc:1"), std::string::npos);
    EXPECT_NE(
        errorOf("BO_ 1 A: 8 X\n SG_ S : 99999999999|8@1+ (1,0) [0|1] \"\" X\n").find("t.dbc:2"),
        std::string::npos);
    EXPECT_NE(errorOf("BO_ 1 A: 8 X\n SG_ S : 0|8@1+ (1e999,0) [0|1] \"\" X\n").find("t.dbc:2"),
              std::string::npos);
    EXPECT_NE(errorOf("BO_ 1 A: 8 X\n SG_ S : 0|8@1+ (1,0) [5|1] \"\" X\n").find("min > max"),
              std::string::npos);
}

TEST(DbcBadInput, DeclaredRangeIsHonoured) {
    const DbcDatabase db = DbcDatabase::parse(
        "BO_ 1 A: 2 X\n SG_ Pitch_deg : 0|16@1- (0.01,0) [-90|90] \"deg\" X\n"
        " SG_ Free : 0|8@1+ (1,0) [0|0] \"\" X\n",
        "t.dbc");
    const DbcSignal& pitch = db.find(1, false)->signals.at(0);
    EXPECT_TRUE(inDeclaredRange(pitch, 90.0));
    EXPECT_TRUE(inDeclaredRange(pitch, -90.004));  // within half a raw step
    EXPECT_FALSE(inDeclaredRange(pitch, 90.01));
    EXPECT_FALSE(inDeclaredRange(pitch, std::numeric_limits<double>::quiet_NaN()));
    const DbcSignal& free = db.find(1, false)->signals.at(1);
    EXPECT_TRUE(inDeclaredRange(free, 1e300));  // [0|0]: no range declared
    EXPECT_FALSE(inDeclaredRange(free, std::numeric_limits<double>::infinity()));
}

TEST(DbcBadInput, EncodeClampsWithoutOverflow) {
    // 2^63 and 2^64 converted to the integer types were undefined behaviour.
    DbcSignal u64;
    u64.length = 64;
    DbcSignal s64 = u64;
    s64.isSigned = true;
    std::uint8_t d[8] = {};
    encodeSignal(u64, 1e30, d, 8);
    for (const std::uint8_t b : d)
        EXPECT_EQ(b, 0xFF);
    encodeSignal(s64, -1e30, d, 8);
    EXPECT_EQ(d[7], 0x80);
    encodeSignal(s64, std::numeric_limits<double>::quiet_NaN(), d, 8);
    EXPECT_EQ(d[7], 0x00);
}

TEST(DbcBadInput, SignedSignalsOf63And64BitsDecode) {
    // Found by the dbc fuzz target: raw − 2^63 overflowed int64 (UBSan) for a 63-bit signal.
    std::uint8_t d[8];
    std::memset(d, 0xFF, sizeof d);
    for (const int len : {63, 64}) {
        DbcSignal s;
        s.length = len;
        s.isSigned = true;
        double v = 0;
        ASSERT_TRUE(decodeSignal(s, d, 8, &v));
        EXPECT_EQ(v, -1.0) << len;  // all ones: −1
    }
    DbcSignal s63;
    s63.length = 63;
    s63.isSigned = true;
    std::uint8_t minimum[8] = {0, 0, 0, 0, 0, 0, 0, 0x40};  // bit 62 alone: −2^62
    double v = 0;
    ASSERT_TRUE(decodeSignal(s63, minimum, 8, &v));
    EXPECT_EQ(v, -std::ldexp(1.0, 62));
}

TEST(CandumpBadInput, TimesAreBounded) {
    double t = 0;
    CanFrame f;
    // 23 digits before the point: a time no candump writes, and one that overflowed the
    // integer conversion when the frame was written back.
    EXPECT_FALSE(parseCandumpLine("(99999999999999999999999.0) can0 100#00", &t, &f));
    EXPECT_FALSE(parseCandumpLine("(1.) can0 100#00", &t, &f));
    EXPECT_FALSE(parseCandumpLine("(1.0000000001) can0 100#00", &t, &f));
    ASSERT_TRUE(parseCandumpLine("(99999999999.999999) can0 100#00", &t, &f));
    EXPECT_DOUBLE_EQ(t, 99999999999.999999);
    char buf[128];
    EXPECT_EQ(formatCandumpLine(1e30, "can0", f, buf, sizeof buf), 0u);
    EXPECT_EQ(formatCandumpLine(-1.0, "can0", f, buf, sizeof buf), 0u);
    EXPECT_EQ(formatCandumpLine(std::nan(""), "can0", f, buf, sizeof buf), 0u);
    EXPECT_GT(formatCandumpLine(1436509052.249713, "can0", f, buf, sizeof buf), 0u);
}

}  // namespace
}  // namespace nvs::drivers
