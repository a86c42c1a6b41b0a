// GammaTable: the MCP's Gamma(N·k) draws by tabulated quantile, against GSL's inverse and CDF
// (an independent implementation of the regularised incomplete gamma function) and the Gamma
// law's moments.

#include "sim/core/gamma_table.h"

#include <gsl/gsl_cdf.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <string>
#include <vector>

#include "sim/core/rng.h"

namespace nvs {
namespace {

// The exact quantile at a word's u, from the side that keeps its precision.
double exactQuantile(double shape, std::uint32_t word) {
    const double u = GammaTable::uniformOf(word);
    return (word >> 31) ? gsl_cdf_gamma_Qinv(1.0 - u, shape, 1.0)
                        : gsl_cdf_gamma_Pinv(u, shape, 1.0);
}

// The word ↔ u mapping covers (0, 1) symmetrically at 2⁻³² steps: the low 31 bits count out
// from each end toward ½.
TEST(GammaTable, WordsMapToTheOpenUnitInterval) {
    EXPECT_DOUBLE_EQ(GammaTable::uniformOf(0u), 0x1.0p-33);
    EXPECT_DOUBLE_EQ(GammaTable::uniformOf(0x80000000u), 1.0 - 0x1.0p-33);
    EXPECT_DOUBLE_EQ(GammaTable::uniformOf(0x7FFFFFFFu), 0.5 - 0x1.0p-33);
    EXPECT_DOUBLE_EQ(GammaTable::uniformOf(0xFFFFFFFFu), 0.5 + 0x1.0p-33);
}

// A draw's quantile is within 1e-4 (relative; 5e-5 at worst over all) of the exact one for every
// shape N·k, random words and the words of both extreme tails, for the PULNiX camera's F = 1.6 and
// for F = 2.
TEST(GammaTable, QuantilesMatchGslWithin1em4) {
    for (double f : {1.6, 2.0}) {
        const double k = 1.0 / (f - 1.0);
        GammaTableCache tables;
        const auto table = tables.forShapeStep(k);
        const PixelRng rng(3, RngStream::Test, 0);
        std::vector<std::uint32_t> words(4096);
        double worst = 0.0;
        for (int n = 1; n <= GammaTable::kMaxN; ++n) {
            rng.rowWords(static_cast<std::uint32_t>(n), 0, 0, 1024, words.data());
            for (std::uint32_t extreme : {0u, 1u, 2u, 1000u, 0x7FFFFFFFu, 0x80000000u, 0x80000001u,
                                          0xFFFFFFFEu, 0xFFFFFFFFu})
                words.push_back(extreme);
            for (std::uint32_t w : words) {
                const double exact = exactQuantile(n * k, w);
                const double got = static_cast<double>(table->quantile(n, w));
                const double rel = std::fabs(got - exact) / exact;
                worst = std::max(worst, rel);
                ASSERT_LT(rel, 1e-4) << "F " << f << " N " << n << " word " << w;
            }
            words.resize(4096);
        }
        std::printf("GammaTable F = %.1f: worst relative quantile error %.2e\n", f, worst);
        EXPECT_LT(worst, 5e-5);
    }
}

// gammaTableDraws: θ·quantile bit for bit for whole N from 1 to kMaxN, 0 for N = 0, −1 (left to
// the caller) for a fraction or N > kMaxN; any length, not only whole vectors.
TEST(GammaTable, RowDrawsEqualSingleQuantiles) {
    GammaTableCache tables;
    const auto table = tables.forShapeStep(1.0 / 0.6);
    const int m = 1000 + 7;
    std::vector<float> n(m), out(m);
    std::vector<std::uint32_t> words(1008);
    PixelRng(5, RngStream::Test, 0).rowWords(0, 0, 0, 252, words.data());
    for (int j = 0; j < m; ++j)
        n[static_cast<std::size_t>(j)] = static_cast<float>(j % 36);  // 0 … 35
    n[17] = 2.5f;
    const float theta = 1234.5f;
    gammaTableDraws(*table, n.data(), words.data(), out.data(), m, theta);
    for (int j = 0; j < m; ++j) {
        const std::size_t i = static_cast<std::size_t>(j);
        const float nj = n[i];
        if (nj == 0.0f) {
            EXPECT_EQ(out[i], 0.0f) << j;
        } else if (nj > 32.0f || nj != std::floor(nj)) {
            EXPECT_EQ(out[i], -1.0f) << j;
        } else {
            EXPECT_EQ(out[i], theta * table->quantile(static_cast<int>(nj), words[i])) << j;
        }
    }
}

// The draws follow Gamma(N·k): mean N·k·θ and variance N·k·θ² (10⁶ draws each, within 5
// standard errors), and a Kolmogorov–Smirnov distance to GSL's CDF below the 0.1 % critical
// value for 10⁶ samples (1.95/√n).
TEST(GammaTable, DrawsHaveTheGammaLaw) {
    const double k = 1.0 / 0.6;
    GammaTableCache tables;
    const auto table = tables.forShapeStep(k);
    const int count = 1 << 20;
    std::vector<std::uint32_t> words(static_cast<std::size_t>(count));
    PixelRng(9, RngStream::Test, 0).rowWords(0, 0, 0, count / 4, words.data());
    for (int n : {1, 3, 32}) {
        const double a = n * k;
        std::vector<float> ns(static_cast<std::size_t>(count), static_cast<float>(n));
        std::vector<float> out(static_cast<std::size_t>(count));
        gammaTableDraws(*table, ns.data(), words.data(), out.data(), count, 1.0f);
        double sum = 0.0, sum2 = 0.0;
        for (float v : out) {
            const double d = static_cast<double>(v);
            sum += d;
            sum2 += d * d;
        }
        const double mean = sum / count;
        const double var = sum2 / count - mean * mean;
        EXPECT_NEAR(mean, a, 5.0 * std::sqrt(a / count)) << n;
        // Var of the sample variance of a Gamma: (μ4 − σ⁴)/n with μ4 = 3a² + 6a.
        EXPECT_NEAR(var, a, 5.0 * std::sqrt((2.0 * a * a + 6.0 * a) / count)) << n;
        std::sort(out.begin(), out.end());
        double ks = 0.0;
        for (int i = 0; i < count; i += 7) {
            const double cdf =
                gsl_cdf_gamma_P(static_cast<double>(out[static_cast<std::size_t>(i)]), a, 1.0);
            ks = std::max({ks, std::fabs(cdf - static_cast<double>(i) / count),
                           std::fabs(cdf - static_cast<double>(i + 1) / count)});
        }
        EXPECT_LT(ks, 1.95 / std::sqrt(static_cast<double>(count))) << n;
        std::printf("N = %d: mean %.5f (%.5f), variance %.5f (%.5f), KS %.2e\n", n, mean, a, var, a,
                    ks);
    }
}

// A cache builds one table per shape step and hands the same one to every caller; another
// cache (another runtime or test) has its own.
TEST(GammaTableCache, SharesOneTablePerShapeStep) {
    GammaTableCache a, b;
    const auto t1 = a.forShapeStep(1.0 / 0.6);
    const auto t2 = a.forShapeStep(1.0 / 0.6);
    const auto t3 = a.forShapeStep(1.0);
    const auto t4 = b.forShapeStep(1.0 / 0.6);
    EXPECT_EQ(t1.get(), t2.get());
    EXPECT_NE(t1.get(), t3.get());
    EXPECT_NE(t1.get(), t4.get());
    EXPECT_DOUBLE_EQ(t3->shapeStep(), 1.0);
    EXPECT_EQ(
        std::memcmp(t1->data(), t4->data(),
                    sizeof(float) *
                        (static_cast<std::size_t>(GammaTable::kMaxN) * GammaTable::kPerShape + 1)),
        0);
}

}  // namespace
}  // namespace nvs
