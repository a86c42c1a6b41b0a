// Scenario values at and past their limits (docs/reliability-inputs.md): a frame rate below
// 0.001 Hz (SIGFPE in the wall clock before), a duration_s so large that the frame count
// overflowed (undefined behaviour, a run that never ends), a date that does not exist, NaN in
// the held pose, and a camera preset that is a FIFO are errors naming file:line.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <string>

#include "rt/compose/scenario.h"
#include "sim/core/error.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::rt {
namespace {

const char* kHead = "[scenario]\nname = \"t\"\n";
const char* kSource = "[[source]]\nkind = \"test_pattern\"\n";

std::string errorOf(const std::string& text) {
    try {
        parseScenario(text, "s.toml", test::configDir());
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

TEST(ScenarioBounds, FrameRateBelowTheMinimumNamesItsLine) {
    const std::string e = errorOf(std::string(kHead) + "frame_rate_hz = 0.0004\n" + kSource);
    EXPECT_NE(e.find("s.toml:3"), std::string::npos) << e;
    EXPECT_NE(e.find("frame_rate_hz"), std::string::npos) << e;
    const Scenario sc = parseScenario(std::string(kHead) + "frame_rate_hz = 0.001\n" + kSource,
                                      "s.toml", test::configDir());
    EXPECT_TRUE(sc.rate.valid());
    WallClock c(sc.rate);  // the clock the run makes from it
    EXPECT_EQ(c.deadline_ns(1), 1'000'000'000'000);
}

TEST(ScenarioBounds, DurationIsBounded) {
    for (const char* d : {"1e300", "inf", "nan", "1.0000001e7"}) {
        const std::string e = errorOf(std::string(kHead) + "duration_s = " + d + "\n" + kSource);
        EXPECT_NE(e.find("s.toml:3"), std::string::npos) << d << ": " << e;
    }
    const Scenario sc = parseScenario(std::string(kHead) + "duration_s = 1e7\n" + kSource, "s.toml",
                                      test::configDir());
    EXPECT_EQ(*sc.duration_s, kMaxDuration_s);
}

TEST(ScenarioBounds, DatesMustExist) {
    double t = 0.0;
    EXPECT_FALSE(parseIso8601Utc("2024-02-31T00:00:00Z", &t));
    EXPECT_FALSE(parseIso8601Utc("2023-02-29T00:00:00Z", &t));
    EXPECT_FALSE(parseIso8601Utc("2024-04-31T00:00:00Z", &t));
    EXPECT_FALSE(parseIso8601Utc("2024-01-01T00:00:nanZ", &t));
    ASSERT_TRUE(parseIso8601Utc("2024-02-29T00:00:00Z", &t));
    EXPECT_DOUBLE_EQ(t, 1709164800.0);
    const std::string e =
        errorOf(std::string(kHead) + "utc_start = \"2024-02-31T00:00:00Z\"\n" + kSource);
    EXPECT_NE(e.find("s.toml:3"), std::string::npos) << e;
}

TEST(ScenarioBounds, NonFiniteValuesNameTheirLine) {
    for (const std::string& bad :
         {std::string("[platform]\nlat_deg = nan\n"), std::string("[platform]\nroll_deg = inf\n"),
          std::string("[platform]\nalt_m = 1e300\n"),
          std::string("[runtime]\nstale_after_s = inf\n"),
          std::string("[[event]]\nt_s = nan\ngain_V = 1.0\n")}) {
        const std::string e = errorOf(std::string(kHead) + kSource + bad);
        EXPECT_NE(e.find("s.toml:6"), std::string::npos) << bad << ": " << e;
    }
}

TEST(ScenarioBounds, OverlongPathsAreSetupErrors) {
    // std::filesystem::exists threw filesystem_error (ENAMETOOLONG) for these.
    const std::string longName(300, 'n');
    for (const std::string& bad : {"[scene]\nfile = \"" + longName + "\"\n",
                                   "[telemetry]\nsource = \"replay:" + longName + "\"\n"}) {
        const std::string e =
            errorOf(std::string(kHead) + "[camera]\npreset = \"pulnix-ag5745ef3\"\n" +
                    (bad[1] == 's' ? "" : std::string(kSource)) + bad);
        EXPECT_NE(e.find("s.toml:"), std::string::npos) << e;
    }
}

TEST(ScenarioBounds, CameraPresetThatIsAFifoIsAnError) {
    const std::string fifo = ::testing::TempDir() + "nvs_preset_fifo.toml";
    ::unlink(fifo.c_str());
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // Opened with no writer, the read blocked forever before.
    const std::string e = errorOf(std::string(kHead) + "[camera]\npreset = \"" + fifo + "\"\n");
    EXPECT_NE(e.find("FIFO"), std::string::npos) << e;
    ::unlink(fifo.c_str());
}

}  // namespace
}  // namespace nvs::rt
