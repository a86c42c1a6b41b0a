// The contact sheet's size check (drivers/sinks): cols · rows of two large ints overflowed
// (undefined behaviour) and could wrap into the accepted range; each factor is bounded first.
#include <gtest/gtest.h>

#include "drivers/sinks/sinks.h"
#include "sim/core/error.h"

namespace nvs::drivers {
namespace {

TEST(ContactSheetSize, LargeColumnAndRowCountsAreRefused) {
    const std::string path = ::testing::TempDir() + "nvs_contact_size.png";
    // 65536 · 65536 = 2³² wraps to 0 in 32-bit arithmetic, which passed the "≤ 64" check.
    for (const auto& [cols, rows] : {std::pair{65536, 65536}, std::pair{100000, 100000},
                                     std::pair{65, 1}, std::pair{1, 65}, std::pair{9, 8}}) {
        EXPECT_THROW(ContactSheetSink(path, 64, 48, 8, cols, rows, 2, 100, 0), SetupError)
            << cols << "x" << rows;
    }
    EXPECT_NO_THROW(ContactSheetSink(path, 64, 48, 8, 8, 8, 2, 100, 0));
    EXPECT_NO_THROW(ContactSheetSink(path, 64, 48, 8, 64, 1, 2, 100, 0));
}

}  // namespace
}  // namespace nvs::drivers
