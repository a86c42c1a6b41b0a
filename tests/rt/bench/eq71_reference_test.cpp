// The plain eq. 7.1 reference (rt/bench/eq71_reference.h) against the laws it implements, on
// flat fields: the Poisson law (variance = mean), the linear gain and bias, the added Gaussian
// noise and the ADC's rounding, and the Gaussian MTF's effect on white noise (Parseval).
#include "rt/bench/eq71_reference.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <numbers>
#include <vector>

namespace nvs::rt::bench {
namespace {

struct Moments {
    double mean = 0.0;
    double var = 0.0;
};

// Mean and variance of the counts over `frames` frames of a flat input.
Moments flatField(const Eq71Params& p, float input, int frames) {
    Eq71Reference ref(p);
    const std::size_t n = static_cast<std::size_t>(p.width) * p.height;
    std::vector<float> in(n, input);
    std::vector<std::uint16_t> out(n);
    double s = 0.0, s2 = 0.0;
    for (int f = 0; f < frames; ++f) {
        ref.process(in.data(), out.data());
        for (const std::uint16_t v : out) {
            s += v;
            s2 += static_cast<double>(v) * v;
        }
    }
    const double count = static_cast<double>(n) * frames;
    Moments m;
    m.mean = s / count;
    m.var = s2 / count - m.mean * m.mean;
    return m;
}

TEST(Eq71Reference, ShotNoiseFollowsThePoissonLaw) {
    // Gain 1, no bias, no added noise, all-pass MTF: the counts are the Poisson draws (the FFT
    // round trip returns integers to within 1e-9, which the rounding removes).
    Eq71Params p;
    p.width = 512;
    p.height = 256;
    p.pe_per_input = 2.0;
    p.mtf_sigma_px = 0.0;
    p.gain_dc_per_pe = 1.0;
    p.adc_bits = 16;
    const Moments m = flatField(p, 20.0f, 4);  // mean 40 pe
    // 524 288 samples: the mean's standard error is 0.009, the variance's 0.08 (σ²·√(2/n)).
    EXPECT_NEAR(m.mean, 40.0, 0.05);
    EXPECT_NEAR(m.var, 40.0, 0.5);
}

TEST(Eq71Reference, GainBiasAndGaussianNoiseAddAsTheLawsSay) {
    // E[g] = G·μ + b; Var[g] = G²·μ + σ_n² + 1/12 (uniform rounding of a continuous value).
    Eq71Params p;
    p.width = 512;
    p.height = 256;
    p.pe_per_input = 1.0;
    p.mtf_sigma_px = 0.0;
    p.gain_dc_per_pe = 0.5;
    p.bias_dc = 20.0;
    p.noise_dc = 3.0;
    p.adc_bits = 8;
    const Moments m = flatField(p, 100.0f, 4);
    EXPECT_NEAR(m.mean, 0.5 * 100.0 + 20.0, 0.05);
    EXPECT_NEAR(m.var, 0.25 * 100.0 + 9.0 + 1.0 / 12.0, 0.5);
}

TEST(Eq71Reference, GaussianMtfKeepsTheMeanAndFiltersWhiteNoise) {
    // A filter H passes white noise of variance v as v·mean(|H|²) over the frequency grid
    // (Parseval); for H = exp(−2π²σ²|ξ|²) with σ ≥ 1 px (H < 1e-4 beyond Nyquist) that mean is
    // ∫∫ exp(−4π²σ²|ξ|²) d²ξ = 1/(4πσ²). H(0) = 1 keeps the mean.
    Eq71Params p;
    p.width = 512;
    p.height = 512;
    p.pe_per_input = 1.0;
    p.mtf_sigma_px = 1.5;
    p.gain_dc_per_pe = 4.0;
    p.bias_dc = 10.0;
    p.adc_bits = 16;
    const double mu = 400.0;
    const Moments m = flatField(p, static_cast<float>(mu), 4);
    const double kept = 1.0 / (4.0 * std::numbers::pi * 1.5 * 1.5);
    const double expectedVar = 16.0 * mu * kept + 1.0 / 12.0;  // ≈ 226
    EXPECT_NEAR(m.mean, 4.0 * mu + 10.0, 0.5);  // standard error 4·√(μ/1.05e6) = 0.08
    // Neighbouring pixels are correlated over ~σ: about 1e6/(4πσ²) ≈ 3.5e4 independent samples,
    // a relative standard error of the variance of ≈ 0.8 %.
    EXPECT_NEAR(m.var / expectedVar, 1.0, 0.04);
    // Without the filter the same field has the full Poisson variance: the filter did act.
    p.mtf_sigma_px = 0.0;
    EXPECT_NEAR(flatField(p, static_cast<float>(mu), 1).var / (16.0 * mu + 1.0 / 12.0), 1.0, 0.02);
}

}  // namespace
}  // namespace nvs::rt::bench
