// The keyed per-pixel RNG: determinism by key whatever the chunking, and exactness of the
// Poisson, normal and Gamma samplers against their laws.
#include "sim/core/rng.h"

#include <Random123/philox.h>
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <limits>
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

double poissonPmf(double mu, int k) {
    return std::exp(-mu + k * std::log(mu) - std::lgamma(k + 1.0));
}

TEST(LogFactorial, MatchesLgamma) {
    for (int k = 0; k < 2000; ++k) {
        EXPECT_NEAR(logFactorial(k), std::lgamma(k + 1.0),
                    1e-9 * std::max(1.0, std::lgamma(k + 1.0)))
            << k;
    }
}

TEST(PixelRng, BlockEqualsRandom123Philox4x32) {
    for (std::uint32_t i = 0; i < 64; ++i) {
        const std::uint32_t key[2] = {0x12345678u * i, ~i};
        const std::uint32_t ctr[4] = {i, 3u * i + 1u, 0xFFFFFFFFu - i, i << 20};
        std::uint32_t mine[4];
        philox4x32Block(key, ctr, mine);
        const r123::Philox4x32::ctr_type c = {{ctr[0], ctr[1], ctr[2], ctr[3]}};
        const r123::Philox4x32::key_type k = {{key[0], key[1]}};
        const r123::Philox4x32::ctr_type r = r123::Philox4x32()(c, k);
        for (int j = 0; j < 4; ++j)
            ASSERT_EQ(mine[j], r.v[j]) << i << " " << j;
    }
}

TEST(PixelRng, RowWordsAreBlocksOfTheDocumentedCounterWhateverTheChunking) {
    const std::uint64_t seed = 0x0123456789ABCDEFull;
    const std::uint64_t frame = 0x0000000500000007ull;
    const PixelRng rng(seed, RngStream::ReadNoise, frame);
    std::vector<std::uint32_t> all(4 * 50), part(4 * 50);
    rng.rowWords(9, 1, 0, 50, all.data());
    rng.rowWords(9, 1, 0, 13, part.data());
    rng.rowWords(9, 1, 13, 37, part.data() + 4 * 13);
    EXPECT_EQ(all, part);
    const std::uint32_t key[2] = {0x89ABCDEFu, 0x01234567u};
    for (std::uint32_t b = 0; b < 50; ++b) {
        const std::uint32_t ctr[4] = {
            (1u << 24) + b, 9u, 7u, (static_cast<std::uint32_t>(RngStream::ReadNoise) << 16) | 5u};
        std::uint32_t ref[4];
        philox4x32Block(key, ctr, ref);
        for (int j = 0; j < 4; ++j)
            ASSERT_EQ(all[4 * b + static_cast<std::uint32_t>(j)], ref[j]) << b;
    }
    for (std::uint32_t b = 0; b < 50; b += 7) {
        std::uint32_t one[4];
        rng.block(9, 1, b, one);
        for (std::uint32_t j = 0; j < 4; ++j)
            ASSERT_EQ(one[j], all[4 * b + j]) << b;
    }
    // A list of blocks (out of order, repeated, a length that is no multiple of the lanes)
    // gives the same words as the row.
    const std::vector<std::uint32_t> list = {49, 0, 3, 3, 17, 2, 48, 11, 30, 1, 5};
    std::vector<std::uint32_t> listed(4 * list.size());
    rng.blocksAt(9, 1, list.data(), static_cast<int>(list.size()), listed.data());
    for (std::size_t i = 0; i < list.size(); ++i)
        for (std::uint32_t j = 0; j < 4; ++j)
            ASSERT_EQ(listed[4 * i + j], all[4 * list[i] + j]) << i;
    // Another plane, row, frame or stream gives other words; a pixel stream meets no row word.
    std::vector<std::uint32_t> other(4 * 50);
    rng.rowWords(9, 0, 0, 50, other.data());
    EXPECT_NE(all, other);
    PixelRng(seed, RngStream::Photocathode, frame).rowWords(9, 1, 0, 50, other.data());
    EXPECT_NE(all, other);
    PixelStream s1 = rng.pixelStream(3, 9), s2 = rng.pixelStream(3, 9), s3 = rng.pixelStream(4, 9);
    for (int i = 0; i < 20; ++i) {
        const std::uint32_t a = s1.next();
        ASSERT_EQ(a, s2.next());
        EXPECT_NE(a, s3.next());
    }
}

// Inversion check against the law itself: the normal from a word has P(|Z| > |z|) equal to
// the word's tail probability q = (w mod 2³¹ + ½)·2⁻³¹, to float precision, over the whole
// range (|z| up to 6.4), and its sign is the word's top bit.
TEST(PixelRng, NormalFromWordInvertsTheNormalLaw) {
    double worst = 0.0;
    for (std::uint64_t m = 0; m < (1ull << 31); m = m * 5 / 4 + 1) {
        for (std::uint32_t sign : {0u, 0x80000000u}) {
            const std::uint32_t w = static_cast<std::uint32_t>(m) | sign;
            const double z = static_cast<double>(normalFromWord(w));
            const double q = (static_cast<double>(m) + 0.5) * 0x1.0p-31;
            const double tail = std::erfc(std::fabs(z) / std::sqrt(2.0));
            // float rounding of q and of z: |Δq/q| ≤ 2⁻²³·(1 + |z|²) roughly; allow 4e-6
            // relative plus the float resolution of q near 1.
            const double err = std::fabs(tail - q) / (q * (1.0 + z * z) + 1e-7 / q);
            worst = std::max(worst, err);
            if (z != 0.0) {
                ASSERT_EQ(z < 0.0, sign != 0u) << w;
            }
        }
    }
    std::printf("normalFromWord: worst scaled tail error %.2e\n", worst);
    EXPECT_LT(worst, 4e-6);
}

TEST(PixelRng, NormalsFromWordsMatchSingleDrawsAndTheNormalLaw) {
    const int n = 1 << 18;
    std::vector<std::uint32_t> words(static_cast<std::size_t>(n));
    PixelRng(3, RngStream::Test, 0).rowWords(0, 0, 0, n / 4, words.data());
    std::vector<float> z(static_cast<std::size_t>(n));
    normalsFromWords(words.data(), z.data(), n - 3);  // a length that is no multiple of 16
    z[static_cast<std::size_t>(n - 3)] = normalFromWord(words[static_cast<std::size_t>(n - 3)]);
    z[static_cast<std::size_t>(n - 2)] = normalFromWord(words[static_cast<std::size_t>(n - 2)]);
    z[static_cast<std::size_t>(n - 1)] = normalFromWord(words[static_cast<std::size_t>(n - 1)]);
    std::vector<double> x(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < x.size(); ++i) {
        ASSERT_EQ(z[i], normalFromWord(words[i])) << i;
        x[i] = static_cast<double>(z[i]);
    }
    const Moments m = moments(x);
    EXPECT_NEAR(m.mean, 0.0, 5.0 / std::sqrt(n));
    EXPECT_NEAR(m.var, 1.0, 5.0 * std::sqrt(2.0 / n));
    std::sort(x.begin(), x.end());
    double d = 0.0;
    for (int i = 0; i < n; ++i) {
        const double cdf = 0.5 * std::erfc(-x[static_cast<std::size_t>(i)] / std::sqrt(2.0));
        d = std::max({d, std::fabs(cdf - static_cast<double>(i) / n),
                      std::fabs(cdf - static_cast<double>(i + 1) / n)});
    }
    EXPECT_LT(d, 1.95 / std::sqrt(n));
}

// The row Poisson sampler against the pmf (χ² as above), on both sides of every switch: the
// vector zero test, inversion, PTRS at 10; and poissonRow equals poissonFromWord pixel by pixel.
TEST(PixelRng, PoissonRowMatchesPmfAndSingleDraws) {
    const int w = 800, rows = 500;
    std::vector<std::uint32_t> words(static_cast<std::size_t>(w));
    std::vector<float> mean(static_cast<std::size_t>(w)), out(static_cast<std::size_t>(w));
    for (double mu : {1e-3, 0.01, 0.7, 4.0, 9.5, 10.0, 17.0, 31.9, 32.0, 60.0, 1e4}) {
        std::fill(mean.begin(), mean.end(), static_cast<float>(mu));
        const PixelRng rng(8, RngStream::Photocathode, static_cast<std::uint64_t>(mu * 10));
        const int kMax = static_cast<int>(mu + 8.0 * std::sqrt(mu) + 10.0);
        std::vector<double> counts(static_cast<std::size_t>(kMax + 1), 0.0);
        std::vector<double> all;
        for (int y = 0; y < rows; ++y) {
            rng.rowWords(static_cast<std::uint32_t>(y), 0, 0, w / 4, words.data());
            poissonRow(mean.data(), words.data(), out.data(), w - 5, rng, 0,
                       static_cast<std::uint32_t>(y));
            for (int x = 0; x < w - 5; ++x) {
                const std::size_t i = static_cast<std::size_t>(x);
                if (y < 4) {
                    PixelStream more = rng.pixelStream(static_cast<std::uint32_t>(x),
                                                       static_cast<std::uint32_t>(y));
                    ASSERT_EQ(static_cast<double>(out[i]),
                              poissonFromWord(static_cast<double>(mean[i]), words[i], more));
                }
                counts[std::min(static_cast<std::size_t>(out[i]),
                                static_cast<std::size_t>(kMax))] += 1.0;
                all.push_back(static_cast<double>(out[i]));
            }
        }
        const double n = static_cast<double>(all.size());
        double chi2 = 0.0, obs = 0.0, exp = 0.0, tail = 1.0;
        int dof = -1;
        for (int k = 0; k <= kMax; ++k) {
            const double p = (k == kMax) ? tail : poissonPmf(mu, k);
            tail -= p;
            obs += counts[static_cast<std::size_t>(k)];
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
        const Moments m = moments(all);
        EXPECT_NEAR(m.mean, mu, 5.0 * std::sqrt(mu / n)) << mu;
        if (dof >= 1) {
            const double z = 3.719;
            const double bound =
                dof * std::pow(1.0 - 2.0 / (9.0 * dof) + z * std::sqrt(2.0 / (9.0 * dof)), 3);
            EXPECT_LT(chi2, bound) << "mu = " << mu << ", dof = " << dof;
        }
    }
    float m0[3] = {0.0f, -1.0f, std::nanf("")};
    const std::uint32_t w0[3] = {0u, 0u, 0u};
    float o0[3];
    poissonRow(m0, w0, o0, 3, PixelRng(1, RngStream::Test, 0), 0, 0);
    EXPECT_EQ(o0[0], 0.0f);
    EXPECT_EQ(o0[1], 0.0f);
    EXPECT_EQ(o0[2], 0.0f);
}

// poissonRow's vector passes (the inversion for sixteen pixels at once in single precision with
// its certainty margin, the double draws where it is not certain or runs past its steps, and
// PTRS's first attempt for eight at once with the stream heads made in bulk) give every draw
// exactly as poissonFromWord does, over means spread across (1e-4, 10) and, on every fourth
// row, (1e-4, 1e3) on a log scale (1.6 million draws).
TEST(PixelRng, PoissonRowVectorPassesEqualSingleDraws) {
    const int w = 800, rows = 2000;
    std::vector<std::uint32_t> words(static_cast<std::size_t>(w));
    std::vector<float> mean(static_cast<std::size_t>(w)), out(static_cast<std::size_t>(w));
    const PixelRng rng(11, RngStream::Photocathode, 3);
    long ones = 0, midInversion = 0, pastVector = 0, ptrs = 0;
    for (int y = 0; y < rows; ++y) {
        // Means from 1e-4 to 10 (the inversion), a different set on each row; every fourth
        // row from 1e-4 to 1e3 (PTRS too).
        const double top = y % 4 == 3 ? 3.0 : 1.0;
        for (int x = 0; x < w; ++x)
            mean[static_cast<std::size_t>(x)] = static_cast<float>(
                std::pow(10.0, top - (top + 4.0) * ((x * 7919 + y * 104729) % w) / w));
        rng.rowWords(static_cast<std::uint32_t>(y), 0, 0, w / 4, words.data());
        poissonRow(mean.data(), words.data(), out.data(), w, rng, 0, static_cast<std::uint32_t>(y));
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(x);
            PixelStream more =
                rng.pixelStream(static_cast<std::uint32_t>(x), static_cast<std::uint32_t>(y));
            ASSERT_EQ(static_cast<double>(out[i]),
                      poissonFromWord(static_cast<double>(mean[i]), words[i], more))
                << x << " " << y;
            ones += out[i] == 1.0f ? 1 : 0;
            midInversion += mean[i] >= 10.0f && mean[i] < 32.0f ? 1 : 0;
            pastVector += mean[i] < 32.0f && out[i] > 40.0f ? 1 : 0;
            ptrs += mean[i] >= 32.0f ? 1 : 0;
        }
    }
    EXPECT_GT(ones, 100000);
    EXPECT_GT(midInversion, 20000);
    EXPECT_GT(pastVector, 10);  // draws that ran far into the vector steps
    EXPECT_GT(ptrs, 40000);
}

// The inversion's start against libm: S(0) = −expm1(−m) and P(N = 1) = m·e^(−m) within 4 ulp
// over (1e-12, 32], small means included (where 1 − e^(−m) would cancel).
TEST(PixelRng, PoissonStartAgreesWithLibm) {
    double worst = 0.0;
    for (int i = 0; i <= 200000; ++i) {
        const double m = std::pow(10.0, -12.0 + (12.0 + std::log10(32.0)) * i / 200000.0);
        double s0 = 0.0, p1 = 0.0;
        poissonStart(m, s0, p1);
        const double refS0 = -std::expm1(-m), refP1 = m * std::exp(-m);
        const double eps = std::numeric_limits<double>::epsilon();
        worst = std::max(
            {worst, std::fabs(s0 - refS0) / (refS0 * eps), std::fabs(p1 - refP1) / (refP1 * eps)});
        ASSERT_LE(std::fabs(s0 - refS0), 4.0 * eps * refS0) << m;
        ASSERT_LE(std::fabs(p1 - refP1), 4.0 * eps * refP1) << m;
    }
    RecordProperty("worst_ulp", std::to_string(worst));
}

// gammaFromNormal with the first normal made beforehand (as the MCP's vector pass does) is
// gammaFromWords, draw for draw, shapes below 1 included.
TEST(PixelRng, GammaFromNormalEqualsGammaFromWords) {
    const PixelRng rng(6, RngStream::McpGain, 2);
    for (double shape : {0.3, 0.6, 1.0, 1.667, 3.33, 20.0}) {
        for (std::uint32_t i = 0; i < 20000; ++i) {
            PixelStream a = rng.pixelStream(i, 7), b = rng.pixelStream(i, 7);
            const std::uint32_t z0 = a.next(), u0 = a.next();
            b.next();
            b.next();
            ASSERT_EQ(gammaFromNormal(shape, 2.0, normalFromWord(z0), u0, b),
                      gammaFromWords(shape, 2.0, z0, u0, a))
                << shape << " " << i;
        }
    }
}

TEST(PixelRng, GammaFromWordsMomentsAndSummedShape) {
    const int n = 200000;
    const PixelRng rng(4, RngStream::McpGain, 1);
    for (double shape : {0.3, 1.0, 1.0 / 0.6, 3.33, 50.0, 1e4}) {
        const double scale = 2.5;
        std::vector<double> x(static_cast<std::size_t>(n));
        for (int i = 0; i < n; ++i) {
            PixelStream s = rng.pixelStream(static_cast<std::uint32_t>(i),
                                            static_cast<std::uint32_t>(shape * 100));
            const std::uint32_t a = s.next(), b = s.next();
            x[static_cast<std::size_t>(i)] = gammaFromWords(shape, scale, a, b, s);
        }
        const Moments m = moments(x);
        const double mean = shape * scale, var = shape * scale * scale;
        const double mu4 = 3.0 * shape * (shape + 2.0) * std::pow(scale, 4);
        EXPECT_NEAR(m.mean, mean, 5.0 * std::sqrt(var / n)) << "shape " << shape;
        EXPECT_NEAR(m.var, var, 5.0 * std::sqrt((mu4 - var * var) / n)) << "shape " << shape;
    }
}

}  // namespace
}  // namespace nvs
