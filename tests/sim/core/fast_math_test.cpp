// The vectorisable 1 − e^(−u) against libm's double-precision expm1 (an independent reference)
// over its whole range, and its limits.
#include "sim/core/fast_math.h"

#include <gtest/gtest.h>

#include <cmath>

namespace nvs {
namespace {

TEST(FastMath, OneMinusExpNegIsWithinTwoUlpsOfExpm1) {
    double worst = 0.0;
    float worstAt = 0.0f;
    int n = 0;
    // Logarithmic steps from 1e-7 to 200 (past the clamp at 87), every region of the
    // function: the series, the branch point 1/2, the reduced exponential, the clamp.
    for (double u = 1e-7; u < 200.0; u *= 1.0003, ++n) {
        const float uf = static_cast<float>(u);
        const double ref = -std::expm1(-static_cast<double>(uf));
        const double rel = std::fabs(static_cast<double>(oneMinusExpNeg(uf)) - ref) / ref;
        if (rel > worst) {
            worst = rel;
            worstAt = uf;
        }
    }
    EXPECT_GT(n, 50000);
    EXPECT_LT(worst, 2.4e-7) << "at u = " << worstAt;  // two float ulps relative
}

TEST(FastMath, OneMinusExpNegLimits) {
    EXPECT_EQ(oneMinusExpNeg(0.0f), 0.0f);
    EXPECT_EQ(oneMinusExpNeg(1e-30f), 1e-30f);  // the series' first term, exactly
    EXPECT_EQ(oneMinusExpNeg(87.0f), 1.0f);
    EXPECT_EQ(oneMinusExpNeg(1e30f), 1.0f);
    // Monotone across the branch point.
    EXPECT_LE(oneMinusExpNeg(std::nextafter(0.5f, 0.0f)), oneMinusExpNeg(0.5f));
}

}  // namespace
}  // namespace nvs
