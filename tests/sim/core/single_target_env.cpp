// For the single-target builds of the samplers (tests/sim/core/CMakeLists.txt): skip every test
// where this CPU cannot run the target the build was compiled for.

#include <gtest/gtest.h>

namespace {

class TargetCheck : public ::testing::Environment {
  public:
    void SetUp() override {
#if defined(__AVX2__) && defined(__GNUC__)
        __builtin_cpu_init();
        if (!__builtin_cpu_supports("avx2") || !__builtin_cpu_supports("fma")) {
            GTEST_SKIP() << "this CPU has no AVX2/FMA: the x86-64-v3 build cannot run here";
        }
#endif
    }
};

const ::testing::Environment* const kTargetCheck =
    ::testing::AddGlobalTestEnvironment(new TargetCheck);

}  // namespace
