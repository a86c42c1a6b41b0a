// DBC decoding against bytes worked out by hand from the DBC bit layout, candump lines, and
// the fake bus's kernel filter rule.
#include "drivers/can/can.h"

#include <gtest/gtest.h>

#include "drivers/can/fake/fake_can.h"

namespace nvs::drivers {
namespace {

const char* kDbc = R"(BO_ 291 TEST: 8 X
 SG_ U12 : 0|12@1+ (1,0) [0|4095] "" Y
 SG_ S8 : 16|8@1- (0.5,-1) [-65|63] "" Y
 SG_ M16 : 39|16@0+ (1,0) [0|65535] "" Y
 SG_ MS4 : 55|4@0- (1,0) [-8|7] "" Y
)";

TEST(Dbc, IntelMotorolaSignedFactorOffset) {
    const DbcDatabase db = DbcDatabase::parse(kDbc, "test.dbc");
    const DbcMessage* m = db.find(291, false);
    ASSERT_NE(m, nullptr);
    // U12 = 0xABC little-endian from bit 0: byte0 = 0xBC, low nibble of byte1 = 0xA.
    // S8 raw 0xF6 = −10 → −10·0.5 − 1 = −6. M16 big-endian from bit 39 (byte 4 MSB) = 0x1234.
    // MS4: bits 55..52 (high nibble of byte 6) = 0xE = −2.
    const std::uint8_t data[8] = {0xBC, 0x0A, 0xF6, 0x00, 0x12, 0x34, 0xE0, 0x00};
    double v = 0;
    ASSERT_TRUE(decodeSignal(m->signals[0], data, 8, &v));
    EXPECT_EQ(v, 0xABC);
    ASSERT_TRUE(decodeSignal(m->signals[1], data, 8, &v));
    EXPECT_EQ(v, -6.0);
    ASSERT_TRUE(decodeSignal(m->signals[2], data, 8, &v));
    EXPECT_EQ(v, 0x1234);
    ASSERT_TRUE(decodeSignal(m->signals[3], data, 8, &v));
    EXPECT_EQ(v, -2.0);
    // A frame too short for a signal is refused, not read past its end.
    EXPECT_FALSE(decodeSignal(m->signals[2], data, 4, &v));
    // encode is decode's inverse.
    std::uint8_t enc[8] = {};
    for (int i = 0; i < 4; ++i) {
        double x = 0;
        decodeSignal(m->signals[static_cast<std::size_t>(i)], data, 8, &x);
        encodeSignal(m->signals[static_cast<std::size_t>(i)], x, enc, 8);
    }
    for (int i = 0; i < 8; ++i)
        EXPECT_EQ(enc[i], data[i]) << i;
}

TEST(Dbc, MalformedLinesNameTheirLine) {
    try {
        DbcDatabase::parse("BO_ 1 A: 8 X\n SG_ broken\n", "bad.dbc");
        FAIL();
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("bad.dbc:2"), std::string::npos) << e.what();
    }
    EXPECT_THROW(DbcDatabase::parse("BO_ 1 A: 2 X\n SG_ S : 8|16@1+ (1,0) [0|1] \"\" X\n", "x"),
                 std::exception);
}

TEST(Dbc, ShippedFileParses) {
    const auto db = DbcDatabase::load(std::string(NVS_SOURCE_DIR) + "/config/can/nvstim.dbc");
    EXPECT_NE(db.find(0x100, false), nullptr);
    const DbcMessage* fd = db.find(0x18FF1000, true);
    ASSERT_NE(fd, nullptr);
    EXPECT_EQ(fd->size, 24);
}

TEST(Candump, ParsesClassicExtendedFdAndRejectsGarbage) {
    double t = 0;
    CanFrame f;
    ASSERT_TRUE(parseCandumpLine("(1436509052.249713) vcan0 044#2A366C2BBA", &t, &f));
    EXPECT_DOUBLE_EQ(t, 1436509052.249713);
    EXPECT_EQ(f.id, 0x44u);
    EXPECT_EQ(f.len, 5);
    EXPECT_EQ(f.data[4], 0xBA);
    ASSERT_TRUE(parseCandumpLine("(1.000000) can0 18FF1000##1112233", &t, &f));
    EXPECT_TRUE(f.fd && f.extended);
    EXPECT_EQ(f.flags, 1);
    EXPECT_EQ(f.len, 3);
    for (const char* bad :
         {"", "garbage", "(1.0) can0 044#2A3", "(1.0) can0 044#112233445566778899",
          "(x) can0 044#00", "(1.0) can0 844#00", "(1.0) can0 04#00"}) {
        EXPECT_FALSE(parseCandumpLine(bad, &t, &f)) << bad;
    }
    char buf[256];
    ASSERT_GT(formatCandumpLine(t, "can0", f, buf, sizeof buf), 0u);
    EXPECT_STREQ(buf, "(1.000000) can0 18FF1000##1112233\n");
}

TEST(FakeCanBus, FiltersAndErrorsLikeTheKernel) {
    FakeCanBus bus;
    ASSERT_EQ(bus.open("vcan0", false, {{0x100, 0x7F0}}), 0);
    CanFrame a;
    a.id = 0x105;
    CanFrame b;
    b.id = 0x200;
    bus.push(b, 1.0);
    bus.push(a, 2.0);
    bus.pushError(ENETDOWN);
    CanFrame got;
    double rx = 0;
    EXPECT_EQ(bus.read(&got, &rx), 1);
    EXPECT_EQ(got.id, 0x105u);
    EXPECT_EQ(bus.read(&got, &rx), -ENETDOWN);
    EXPECT_EQ(bus.state(), CanBusState::Failed);
    EXPECT_EQ(bus.counters().errors, 1);
}

TEST(SocketCanBus, AbsentInterfaceIsAnErrorNotACrash) {
    SocketCanBus bus;
    const int rc = bus.open("nvsnone0", false, {});
    EXPECT_LT(rc, 0);  // ENODEV, or EAFNOSUPPORT without the can module
    EXPECT_NE(bus.state(), CanBusState::Open);
}

}  // namespace
}  // namespace nvs::drivers
