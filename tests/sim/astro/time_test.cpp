// UTC parsing, validation and time scales.

#include "sim/astro/time.h"

#include <erfa.h>
#include <gtest/gtest.h>

#include <string>

#include "sim/core/error.h"

namespace nvs::astro {
namespace {

std::string errorOf(const std::string& text) {
    try {
        parseIsoUtc(text);
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

TEST(ParseIsoUtc, AcceptsTheIso8601Forms) {
    const CalendarInstant a = parseIsoUtc("2024-01-25T17:54:00Z");
    EXPECT_EQ(a.year, 2024);
    EXPECT_EQ(a.month, 1);
    EXPECT_EQ(a.day, 25);
    EXPECT_EQ(a.hour, 17);
    EXPECT_EQ(a.minute, 54);
    EXPECT_DOUBLE_EQ(a.second, 0.0);
    const CalendarInstant b = parseIsoUtc("2024-01-25 17:54:30.25");
    EXPECT_DOUBLE_EQ(b.second, 30.25);
    // EDT = UTC−4: 1998-09-06 22:00 local is 1998-09-07 02:00 UTC.
    const CalendarInstant c = parseIsoUtc("1998-09-06T22:00-04:00");
    EXPECT_EQ(c.day, 7);
    EXPECT_EQ(c.hour, 2);
    EXPECT_EQ(c.minute, 0);
}

TEST(ParseIsoUtc, RejectsMalformedAndOutOfRangeWithTheArgumentName) {
    for (const char* bad : {"", "yesterday", "2024-13-01T00:00Z", "2024-02-30T00:00Z",
                            "2023-02-29T00:00Z", "2024-01-25T25:00Z", "2024-01-25T12:60Z",
                            "2024-01-25T12:00:00X", "2024-01-25", "2024-1-25T12:00Z"}) {
        const std::string e = errorOf(bad);
        EXPECT_EQ(e.rfind("--utc: ", 0), 0u) << "'" << bad << "' gave '" << e << "'";
        EXPECT_EQ(e.find('\n'), std::string::npos);
    }
    const std::string y3000 = errorOf("3000-01-01T00:00Z");
    EXPECT_NE(y3000.find("year 3000"), std::string::npos) << y3000;
    EXPECT_NO_THROW(parseIsoUtc("2024-02-29T00:00Z"));
}

TEST(ParseIsoUtc, LongFractionOfASecondIsNotAnException) {
    // std::stod threw std::out_of_range (underflow) on this fraction: exit 1, no message.
    const std::string tiny = "2024-01-25T17:54:00." + std::string(400, '0') + "1Z";
    EXPECT_DOUBLE_EQ(parseIsoUtc(tiny).second, 0.0);
}

// TT − UT1: 32.184 s + ΔAT in the leap-second era (ΔAT = 37 s since 2017, 32 s in 2000), and
// the Espenak–Meeus polynomial before 1960 (29.07 s at 1950.0 from its published table).
TEST(DeltaT, LeapSecondTableAndPolynomial) {
    EXPECT_DOUBLE_EQ(deltaTForUtc_s(parseIsoUtc("2024-01-25T00:00Z")), 69.184);
    EXPECT_DOUBLE_EQ(deltaTForUtc_s(parseIsoUtc("2000-01-01T00:00Z")), 64.184);
    EXPECT_NEAR(deltaTForUtc_s(parseIsoUtc("1950-01-01T00:00Z")), 29.07, 0.05);
    // Continuity at 1960 (pre-UTC polynomial vs. 1960's 1.4178 s + 32.184 s): within 0.2 s.
    EXPECT_NEAR(deltaTForUtc_s(parseIsoUtc("1959-12-31T23:59Z")),
                deltaTForUtc_s(parseIsoUtc("1960-01-01T00:01Z")), 0.2);
}

TEST(AstroTime, Ut1JulianDateAndPlusSeconds) {
    const AstroTime t = astroTimeFromUtc(parseIsoUtc("2000-01-01T12:00:00Z"));
    EXPECT_NEAR(t.ut1Jd1 + t.ut1Jd2, 2451545.0, 1e-9);
    EXPECT_NEAR((t.ttJd1 + t.ttJd2 - 2451545.0) * 86400.0, 64.184, 1e-4);
    const AstroTime u = t.plusSeconds(3600.0);
    EXPECT_NEAR((u.ut1Jd1 + u.ut1Jd2 - 2451545.0) * 24.0, 1.0, 1e-7);
}

}  // namespace
}  // namespace nvs::astro
