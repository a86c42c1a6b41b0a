// The keyed RNG: determinism by key, independence from threading, and exactness of the
// Poisson, Gaussian and Gamma samplers against their laws.
#include "sim/core/rng.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <thread>
#include <vector>

#include "sim/core/image.h"

namespace nvs {
namespace {

struct Moments {
    double mean = 0.0;
    double var = 0.0;
};

Moments moments(const std::vector<double>& x) {
    // Two-pass for accuracy at large means.
    double s = 0.0;
    for (double v : x)
        s += v;
    const double m = s / static_cast<double>(x.size());
    double ss = 0.0;
    for (double v : x)
        ss += (v - m) * (v - m);
    return {m, ss / static_cast<double>(x.size() - 1)};
}

TEST(KeyedRng, SameKeySameNumbers) {
    KeyedRng a(42, RngStream::Test, 7, 3, 5);
    KeyedRng b(42, RngStream::Test, 7, 3, 5);
    for (int i = 0; i < 1000; ++i)
        ASSERT_EQ(a.nextU64(), b.nextU64());
}

TEST(KeyedRng, EveryKeyComponentChangesTheSequence) {
    const auto first = [](KeyedRng r) { return r.nextU64(); };
    const std::uint64_t base = first(KeyedRng(42, RngStream::Test, 7, 3, 5));
    EXPECT_NE(base, first(KeyedRng(43, RngStream::Test, 7, 3, 5)));
    EXPECT_NE(base, first(KeyedRng(42, RngStream::Photocathode, 7, 3, 5)));
    EXPECT_NE(base, first(KeyedRng(42, RngStream::Test, 8, 3, 5)));
    EXPECT_NE(base, first(KeyedRng(42, RngStream::Test, 7, 4, 5)));
    EXPECT_NE(base, first(KeyedRng(42, RngStream::Test, 7, 3, 6)));
    // x and y are not interchangeable.
    EXPECT_NE(first(KeyedRng(42, RngStream::Test, 7, 3, 5)),
              first(KeyedRng(42, RngStream::Test, 7, 5, 3)));
}

TEST(KeyedRng, UniformIsInOpenUnitIntervalWithRightMoments) {
    KeyedRng r(1, RngStream::Test, 0, 0, 0);
    std::vector<double> u(200000);
    for (double& v : u) {
        v = r.uniform();
        ASSERT_GT(v, 0.0);
        ASSERT_LT(v, 1.0);
    }
    const Moments m = moments(u);
    EXPECT_NEAR(m.mean, 0.5, 5.0 * std::sqrt(1.0 / 12.0 / static_cast<double>(u.size())));
    EXPECT_NEAR(m.var, 1.0 / 12.0, 0.002);
}

// A noise image filled by one thread and by two threads (rows split between them, the second
// thread working bottom-up) is bit-identical.
void fillNoise(ImageView<float> img, int y0, int y1, bool reverse, std::uint64_t frame) {
    for (int i = 0; i < y1 - y0; ++i) {
        const int y = reverse ? y1 - 1 - i : y0 + i;
        for (int x = 0; x < img.width(); ++x) {
            KeyedRng r(99, RngStream::Photocathode, frame, x, y);
            img(x, y) = static_cast<float>(r.poisson(3.7) + r.gaussian() + r.gamma(2.0, 1.5));
        }
    }
}

TEST(KeyedRng, SameNumbersWithOneAndTwoThreads) {
    const int w = 320, h = 240;
    ImageF one(w, h), two(w, h);
    fillNoise(one.view(), 0, h, false, 11);
    std::thread t1([&] { fillNoise(two.view(), 0, h / 3, false, 11); });
    std::thread t2([&] { fillNoise(two.view(), h / 3, h, true, 11); });
    t1.join();
    t2.join();
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x)
            ASSERT_EQ(one(x, y), two(x, y)) << x << "," << y;
    }
}

// Poisson: mean and variance both equal μ, from 0.01 to 1e6. Tolerances are 5 standard
// errors: SE(mean) = √(μ/n); SE(var) = √((μ4 − σ⁴)/n) with μ4 = μ(1 + 3μ) for a Poisson law.
TEST(KeyedRng, PoissonMeanAndVarianceEqualMeanFrom0p01To1e6) {
    const int n = 200000;
    for (double mu :
         {0.01, 0.1, 0.5, 1.0, 3.0, 9.99, 10.0, 12.5, 30.0, 100.0, 1e3, 1e4, 1e5, 1e6}) {
        std::vector<double> x(n);
        for (int i = 0; i < n; ++i) {
            KeyedRng r(5, RngStream::Test, static_cast<std::uint64_t>(mu * 1000), i, 0);
            x[i] = r.poisson(mu);
            ASSERT_EQ(x[i], std::floor(x[i]));
            ASSERT_GE(x[i], 0.0);
        }
        const Moments m = moments(x);
        const double seMean = std::sqrt(mu / n);
        const double seVar = std::sqrt((mu * (1.0 + 3.0 * mu) - mu * mu) / n);
        EXPECT_NEAR(m.mean, mu, 5.0 * seMean) << "mu = " << mu;
        EXPECT_NEAR(m.var, mu, 5.0 * seVar) << "mu = " << mu;
    }
}

double poissonPmf(double mu, int k) {
    return std::exp(-mu + k * std::log(mu) - std::lgamma(k + 1.0));
}

// Exactness, not just moments: the histogram of draws against the Poisson pmf (Pearson χ²),
// on both sides of the inversion / PTRS switch at μ = 10. The bound is the χ² quantile at
// p = 1e-4 (Wilson–Hilferty), so a correct sampler fails with probability 1e-4 per case.
TEST(KeyedRng, PoissonHistogramMatchesPmf) {
    const int n = 400000;
    for (double mu : {0.01, 0.7, 4.0, 9.5, 10.0, 17.0, 60.0}) {
        const int kMax = static_cast<int>(mu + 8.0 * std::sqrt(mu) + 10.0);
        std::vector<double> counts(kMax + 1, 0.0);
        for (int i = 0; i < n; ++i) {
            KeyedRng r(8, RngStream::Test, 0, i, static_cast<std::uint32_t>(mu * 10));
            counts[std::min(static_cast<int>(r.poisson(mu)), kMax)] += 1.0;
        }
        // Pool cells with expected count < 20 into neighbours.
        double chi2 = 0.0;
        int dof = -1;
        double obs = 0.0, exp = 0.0, tail = 1.0;
        for (int k = 0; k <= kMax; ++k) {
            const double p = (k == kMax) ? tail : poissonPmf(mu, k);
            tail -= p;
            obs += counts[k];
            exp += n * p;
            if (exp >= 20.0 && (n * tail >= 20.0 || k == kMax)) {
                chi2 += (obs - exp) * (obs - exp) / exp;
                ++dof;
                obs = exp = 0.0;
            }
        }
        if (exp > 0.0) {
            chi2 += (obs - exp) * (obs - exp) / exp;
            ++dof;
        }
        ASSERT_GE(dof, 1);
        const double z = 3.719;  // upper 1e-4 normal quantile
        const double bound =
            dof * std::pow(1.0 - 2.0 / (9.0 * dof) + z * std::sqrt(2.0 / (9.0 * dof)), 3);
        EXPECT_LT(chi2, bound) << "mu = " << mu << ", dof = " << dof;
    }
}

TEST(KeyedRng, GaussianHasUnitNormalMomentsAndCdf) {
    const int n = 200000;
    std::vector<double> x(n);
    KeyedRng r(3, RngStream::Test, 0, 0, 0);
    for (double& v : x)
        v = r.gaussian();
    const Moments m = moments(x);
    EXPECT_NEAR(m.mean, 0.0, 5.0 / std::sqrt(n));
    EXPECT_NEAR(m.var, 1.0, 5.0 * std::sqrt(2.0 / n));
    // Kolmogorov–Smirnov against Φ; critical value at α = 0.001 is 1.95/√n.
    std::sort(x.begin(), x.end());
    double d = 0.0;
    for (int i = 0; i < n; ++i) {
        const double cdf = 0.5 * std::erfc(-x[i] / std::sqrt(2.0));
        d = std::max({d, std::fabs(cdf - static_cast<double>(i) / n),
                      std::fabs(cdf - static_cast<double>(i + 1) / n)});
    }
    EXPECT_LT(d, 1.95 / std::sqrt(n));
}

TEST(KeyedRng, GammaMeanAndVariance) {
    const int n = 200000;
    for (double shape : {0.3, 1.0, 3.33, 50.0, 1e4}) {
        const double scale = 2.5;
        std::vector<double> x(n);
        for (int i = 0; i < n; ++i) {
            KeyedRng r(4, RngStream::McpGain, static_cast<std::uint64_t>(shape * 100), i, 1);
            x[i] = r.gamma(shape, scale);
            ASSERT_GE(x[i], 0.0);
        }
        const Moments m = moments(x);
        const double mean = shape * scale, var = shape * scale * scale;
        // SE(var) = √((μ4 − σ⁴)/n), with μ4 = 3k(k + 2)θ⁴ for a Gamma law.
        const double mu4 = 3.0 * shape * (shape + 2.0) * std::pow(scale, 4);
        EXPECT_NEAR(m.mean, mean, 5.0 * std::sqrt(var / n)) << "shape " << shape;
        EXPECT_NEAR(m.var, var, 5.0 * std::sqrt((mu4 - var * var) / n)) << "shape " << shape;
    }
}

// The property the MCP model rests on: the sum of N independent Gamma(k, θ) single-electron
// gains is Gamma(N·k, θ). Two-sample Kolmogorov–Smirnov between explicit sums and single
// draws; critical value at α = 0.001 is 1.95·√(2/n).
TEST(KeyedRng, SumOfGammasIsGammaWithSummedShape) {
    const int n = 40000;
    for (int nElectrons : {1, 3, 10}) {
        const double k = 1.0 / (1.6 - 1.0);  // excess noise factor F = 1.6
        const double theta = 1000.0 / k;     // mean gain 1000
        std::vector<double> sums(n), single(n);
        for (int i = 0; i < n; ++i) {
            KeyedRng a(6, RngStream::McpGain, nElectrons, i, 0);
            double s = 0.0;
            for (int e = 0; e < nElectrons; ++e)
                s += a.gamma(k, theta);
            sums[i] = s;
            KeyedRng b(7, RngStream::McpGain, nElectrons, i, 0);
            single[i] = b.gamma(nElectrons * k, theta);
        }
        std::sort(sums.begin(), sums.end());
        std::sort(single.begin(), single.end());
        double d = 0.0;
        std::size_t i = 0, j = 0;
        while (i < sums.size() && j < single.size()) {
            if (sums[i] <= single[j]) {
                ++i;
            } else {
                ++j;
            }
            d = std::max(d, std::fabs(static_cast<double>(i) / n - static_cast<double>(j) / n));
        }
        EXPECT_LT(d, 1.95 * std::sqrt(2.0 / n)) << "N = " << nElectrons;
        // And the moments of the sum: mean N·G, variance N·G²·(F − 1).
        const Moments m = moments(sums);
        EXPECT_NEAR(m.mean / (nElectrons * 1000.0), 1.0, 0.02);
        EXPECT_NEAR(m.var / (nElectrons * 1000.0 * 1000.0 * 0.6), 1.0, 0.06);
    }
}

TEST(KeyedRng, LogFactorialMatchesLgamma) {
    for (int k = 0; k < 2000; ++k) {
        EXPECT_NEAR(logFactorial(k), std::lgamma(k + 1.0),
                    1e-9 * std::max(1.0, std::lgamma(k + 1.0)))
            << k;
    }
}

TEST(KeyedRng, DegenerateParametersGiveZero) {
    KeyedRng r(1, RngStream::Test, 0, 0, 0);
    EXPECT_EQ(r.poisson(0.0), 0.0);
    EXPECT_EQ(r.poisson(-1.0), 0.0);
    EXPECT_EQ(r.poisson(std::nan("")), 0.0);
    EXPECT_EQ(r.gamma(0.0, 1.0), 0.0);
}

}  // namespace
}  // namespace nvs
