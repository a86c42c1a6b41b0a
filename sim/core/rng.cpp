#include "sim/core/rng.h"

#include <Random123/philox.h>

#include <cmath>

#include "sim/core/units.h"

namespace nvs {

KeyedRng::KeyedRng(RngKey key, std::uint64_t frame, std::uint32_t x, std::uint32_t y)
    : key_{key.seed, key.stream}, ctr_{frame, (static_cast<std::uint64_t>(y) << 32) | x, 0, 0} {}

void KeyedRng::refill() {
    using Philox = r123::Philox4x64;
    const Philox::ctr_type c = {{ctr_[0], ctr_[1], ctr_[2], ctr_[3]}};
    const Philox::key_type k = {{key_[0], key_[1]}};
    const Philox::ctr_type r = Philox()(c, k);
    for (int i = 0; i < 4; ++i)
        out_[i] = r.v[i];
    ++ctr_[2];
    used_ = 0;
}

std::uint64_t KeyedRng::nextU64() {
    if (used_ == 4) refill();
    return out_[used_++];
}

double KeyedRng::uniform() {
    // (u >> 11 + 0.5) · 2⁻⁵³ lies in (0, 1): never 0, never 1, so log(u) is always finite.
    return (static_cast<double>(nextU64() >> 11) + 0.5) * 0x1.0p-53;
}

double KeyedRng::gaussian() {
    if (hasSpare_) {
        hasSpare_ = false;
        return spareGaussian_;
    }
    const double r = std::sqrt(-2.0 * std::log(uniform()));
    const double phi = kTwoPi * uniform();
    spareGaussian_ = r * std::sin(phi);
    hasSpare_ = true;
    return r * std::cos(phi);
}

double logFactorial(double k) {
    static constexpr double kTable[16] = {
        0.0,
        0.0,
        0.69314718055994530942,
        1.79175946922805500081,
        3.17805383034794561964,
        4.78749174278204599425,
        6.57925121201010099506,
        8.52516136106541430017,
        10.60460290274525022842,
        12.80182748008146961121,
        15.10441257307551529523,
        17.50230784587388583929,
        19.98721449566188614952,
        22.55216385312342288557,
        25.19122118273868150009,
        27.89927138384089156609,
    };
    if (k < 16.0) return kTable[static_cast<int>(k)];
    // Stirling's series for ln Γ(x), x = k + 1.
    const double x = k + 1.0;
    const double ix = 1.0 / x;
    const double ix2 = ix * ix;
    return (x - 0.5) * std::log(x) - x + 0.91893853320467274178 +
           ix * (1.0 / 12.0 - ix2 * (1.0 / 360.0 - ix2 * (1.0 / 1260.0 - ix2 / 1680.0)));
}

double KeyedRng::poisson(double mean) {
    if (!(mean > 0.0)) return 0.0;
    if (mean < 10.0) {
        // Inversion: the smallest k with F(k) ≥ u. The loop bound guards against a u within
        // rounding of 1; P(k > mean + 60) is below 1e-30 for mean < 10.
        const double u = uniform();
        double p = std::exp(-mean);
        double cdf = p;
        double k = 0.0;
        while (u > cdf && k < mean + 60.0) {
            k += 1.0;
            p *= mean / k;
            cdf += p;
        }
        return k;
    }
    // PTRS (Hörmann 1993, algorithm PTRS with the constants of his Table 1).
    const double slam = std::sqrt(mean);
    const double loglam = std::log(mean);
    const double b = 0.931 + 2.53 * slam;
    const double a = -0.059 + 0.02483 * b;
    const double invalpha = 1.1239 + 1.1328 / (b - 3.4);
    const double vr = 0.9277 - 3.6224 / (b - 2.0);
    for (;;) {
        const double u = uniform() - 0.5;
        const double v = uniform();
        const double us = 0.5 - std::fabs(u);
        const double k = std::floor((2.0 * a / us + b) * u + mean + 0.43);
        if (us >= 0.07 && v <= vr) return k;
        if (k < 0.0 || (us < 0.013 && v > us)) continue;
        if (std::log(v) + std::log(invalpha) - std::log(a / (us * us) + b) <=
            -mean + k * loglam - logFactorial(k)) {
            return k;
        }
    }
}

double KeyedRng::gamma(double shape, double scale) {
    if (!(shape > 0.0)) return 0.0;
    if (shape < 1.0) {
        // Gamma(a) = Gamma(a + 1) · U^(1/a) (Marsaglia & Tsang 2000, §6).
        const double g = gamma(shape + 1.0, 1.0);
        return scale * g * std::pow(uniform(), 1.0 / shape);
    }
    const double d = shape - 1.0 / 3.0;
    const double c = 1.0 / std::sqrt(9.0 * d);
    for (;;) {
        double x = 0.0;
        double v = 0.0;
        do {
            x = gaussian();
            v = 1.0 + c * x;
        } while (v <= 0.0);
        v = v * v * v;
        const double u = uniform();
        const double x2 = x * x;
        if (u < 1.0 - 0.0331 * x2 * x2) return scale * d * v;
        if (std::log(u) < 0.5 * x2 + d * (1.0 - v + std::log(v))) return scale * d * v;
    }
}

}  // namespace nvs
