// Replays every seed corpus (tests/fuzz/<target>/corpus) through the fuzz targets' entry points:
// the same code libFuzzer runs under ASan+UBSan (`make fuzz`), here with the release compiler,
// so each crash once found and added to a corpus stays fixed.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <iterator>
#include <ostream>
#include <string>
#include <vector>

#include "tests/fuzz/fuzz_targets.h"

namespace nvs::fuzz {

// The target's name in test names and messages (not its bytes); found by GoogleTest through
// argument-dependent lookup, so in Target's namespace.
void PrintTo(const Target& t, std::ostream* os);
void PrintTo(const Target& t, std::ostream* os) {
    *os << t.name;
}

namespace {

class Corpus : public ::testing::TestWithParam<Target> {};

TEST_P(Corpus, EverySeedIsHandled) {
    const Target t = GetParam();
    const std::filesystem::path dir =
        std::filesystem::path(NVS_SOURCE_DIR) / "tests" / "fuzz" / t.name / "corpus";
    ASSERT_TRUE(std::filesystem::is_directory(dir)) << dir;
    int seeds = 0;
    for (const auto& e : std::filesystem::directory_iterator(dir)) {
        if (!e.is_regular_file()) continue;
        std::ifstream in(e.path(), std::ios::binary);
        const std::vector<char> bytes((std::istreambuf_iterator<char>(in)),
                                      std::istreambuf_iterator<char>());
        SCOPED_TRACE(e.path().string());
        // A finding aborts the process (fuzz_targets.h); an exception other than SetupError
        // escapes and fails here.
        EXPECT_EQ(t.run(reinterpret_cast<const std::uint8_t*>(bytes.data()), bytes.size()), 0);
        ++seeds;
    }
    EXPECT_GE(seeds, 3) << "a corpus needs seeds: " << dir;
}

INSTANTIATE_TEST_SUITE_P(Fuzz, Corpus, ::testing::ValuesIn(kTargets),
                         [](const ::testing::TestParamInfo<Target>& i) {
                             return std::string(i.param.name);
                         });

}  // namespace
}  // namespace nvs::fuzz
