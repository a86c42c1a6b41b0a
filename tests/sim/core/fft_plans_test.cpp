// sim/core/fft_plans.h: the shipped wisdom's plans where it holds the problem, the scalar
// estimate where it does not, a setup error where FFTW gives no plan at all, and the flags each
// planning mode asks FFTW for (docs/portability.md, "The blur's FFT plans").

#include "sim/core/fft_plans.h"

#include <fftw3.h>
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "sim/core/error.h"
#include "tests/sim/core/test_paths.h"

namespace nvs {
namespace {

TEST(FftPlans, FlagsOfEachPlanning) {
    EXPECT_EQ(fftPlannerFlags(FftPlanning::Shipped), FFTW_MEASURE | FFTW_WISDOM_ONLY);
    EXPECT_EQ(fftPlannerFlags(FftPlanning::Measure, FFTW_DESTROY_INPUT),
              FFTW_MEASURE | FFTW_DESTROY_INPUT);
    EXPECT_EQ(fftPlannerFlags(FftPlanning::Patient), unsigned{FFTW_PATIENT});
}

// The intensified chain's blur plans rows of 800 (768 × 494 presets): in the shipped wisdom. A
// length no preset has (1000) is not: the scalar estimate, which still transforms correctly.
TEST(FftPlans, ShippedWisdomElseScalarEstimate) {
    importShippedFftWisdom(test::configDir());
    float* re = fftwf_alloc_real(1000);
    fftwf_complex* sp = fftwf_alloc_complex(501);
    const unsigned flags = fftPlannerFlags(FftPlanning::Shipped);
    bool fromWisdom = false;
    fftwf_plan p =
        planFromWisdomOrEstimate([&](unsigned f) { return fftwf_plan_dft_r2c_1d(800, re, sp, f); },
                                 flags, "test", &fromWisdom);
    EXPECT_TRUE(fromWisdom);
    fftwf_destroy_plan(p);
    p = planFromWisdomOrEstimate([&](unsigned f) { return fftwf_plan_dft_r2c_1d(1000, re, sp, f); },
                                 flags, "test", &fromWisdom);
    EXPECT_FALSE(fromWisdom);
    // cos(2π·5x/N): the spectrum is N/2 at bin 5 and 0 elsewhere (the DFT's definition).
    for (int i = 0; i < 1000; ++i)
        re[i] = static_cast<float>(std::cos(2.0 * 3.14159265358979323846 * 5.0 * i / 1000.0));
    fftwf_execute(p);
    for (int k = 0; k <= 500; ++k) {
        const double mag = std::hypot(static_cast<double>(sp[k][0]), static_cast<double>(sp[k][1]));
        EXPECT_NEAR(mag, k == 5 ? 500.0 : 0.0, 1e-3) << k;
    }
    fftwf_destroy_plan(p);
    fftwf_free(re);
    fftwf_free(sp);
}

TEST(FftPlans, NoPlanAtAllIsASetupErrorNamingTheCaller) {
    int calls = 0;
    try {
        planFromWisdomOrEstimate(
            [&](unsigned) -> fftwf_plan {
                ++calls;
                return nullptr;
            },
            fftPlannerFlags(FftPlanning::Shipped), "optics");
        FAIL() << "no SetupError";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("optics: FFTW could not plan"), std::string::npos)
            << e.what();
    }
    EXPECT_EQ(calls, 2);  // the wisdom, then the estimate
}

TEST(FftPlans, EmptyConfigFolderImportsNothing) {
    importShippedFftWisdom({});  // no file looked for: nothing to fail
    SUCCEED();
}

}  // namespace
}  // namespace nvs
