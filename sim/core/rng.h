#pragma once
// Keyed, counter-based random numbers (DESIGN §3).
//
// The noise of pixel (x, y) in frame k of stream s is a pure function of (seed, s, k, x, y):
// a KeyedRng built from that key yields the same sequence of draws on any thread, in any
// order, with any tiling. The generator is Philox4x64-10 (Salmon, Moraes, Dror & Shaw,
// "Parallel random numbers: as easy as 1, 2, 3", SC 2011) from Debian's Random123 headers:
// key = (seed, stream), counter = (frame, y·2³² + x, block, 0); each block yields four 64-bit
// words and `block` counts blocks drawn for this key.
//
// The distributions are exact samplers (no normal approximations):
//   poisson   mean < 10: inversion by sequential search (exact, ~mean+1 uniforms);
//             mean ≥ 10: PTRS, Hörmann (1993) "The transformed rejection method for
//             generating Poisson random variables" — exact, O(1) (~2.3 uniforms) at any mean.
//   gaussian  Box–Muller (both variates used).
//   gamma     Marsaglia & Tsang (2000) "A simple method for generating gamma variables" for
//             shape ≥ 1; shape < 1 by Gamma(a+1)·U^(1/a).
// No allocation and no exceptions: safe in the frame loop.

#include <cstdint>

namespace nvs {

struct RngKey {
    std::uint64_t seed = 0;
    std::uint32_t stream = 0;
};

// Streams that stages draw from, so no two stages ever share numbers.
enum class RngStream : std::uint32_t {
    Test = 0,
    Photocathode = 1,
    McpGain = 2,
    Ebi = 3,
    ReadNoise = 4,
    FixedPattern = 5,
    Scene = 6,
};

class KeyedRng {
  public:
    KeyedRng(RngKey key, std::uint64_t frame, std::uint32_t x, std::uint32_t y);
    KeyedRng(std::uint64_t seed, RngStream stream, std::uint64_t frame, std::uint32_t x,
             std::uint32_t y)
        : KeyedRng(RngKey{seed, static_cast<std::uint32_t>(stream)}, frame, x, y) {}

    std::uint64_t nextU64();
    // Uniform on the open interval (0, 1), 53-bit resolution.
    double uniform();
    double gaussian();
    // An integer-valued double; mean ≤ 0 gives 0.
    double poisson(double mean);
    // Gamma(shape, scale): mean shape·scale, variance shape·scale². shape ≤ 0 gives 0.
    double gamma(double shape, double scale);

  private:
    void refill();

    std::uint64_t key_[2];
    std::uint64_t ctr_[4];
    std::uint64_t out_[4] = {0, 0, 0, 0};
    int used_ = 4;
    double spareGaussian_ = 0.0;
    bool hasSpare_ = false;
};

// ln(k!) for k ≥ 0: a table below 16, Stirling's series above (error < 1e-12). Exposed for
// tests.
double logFactorial(double k);

}  // namespace nvs
