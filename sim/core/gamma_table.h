#pragma once
// Gamma draws from one noise word by a tabulated quantile function (docs/design.md §3, §4.5).
//
// The MCP stage draws Gamma(N·k) for every pixel that received N ≥ 1 photoelectrons, with one
// fixed k = 1/(F − 1) per camera: a few shapes, hundreds of thousands of draws per field. A
// rejection sampler (Marsaglia–Tsang) needs two words, a normal, and a scalar retry for ~10 %
// of draws; the quantile function Q_a(u) of each shape a = N·k tabulated once turns a draw into
// one word, a table read and a linear interpolation, in vector code with no retries.
//
// The word: its top bit picks the half (u < ½ or u > ½), its other 31 bits i give
// t = (i + ½)·2⁻³¹ ∈ (0, 1), and u = t/2 or 1 − t/2 (so u is uniform on (0, 1) at 2⁻³² steps,
// and either tail is reached in full resolution). The table holds Q at the points
// t = 2^(o−1)·(1 + c/64)·2⁻³¹, o = 0 … 31, c = 0 … 63 (64 points per octave of t, 32 octaves,
// and t = 1): the octave and cell of t are its float's exponent and top six mantissa bits, and
// the next 17 bits are the interpolation fraction. Relative to the exact quantile the error is
// at most 2.2e-5, in the body and out to either end alike (GammaTable tests: a draw's error
// against GSL's inverse for random and extreme words, moments, and a KS test against GSL's CDF).
// The quantiles come from GSL (gsl_cdf_gamma_Pinv / Qinv, the upper tail inverted on Q itself so
// that it keeps its relative accuracy out to 1 − u = 2⁻³³).

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>

namespace nvs {

class GammaTable {
  public:
    static constexpr int kCellsPerOctave = 64;
    static constexpr int kOctaves = 32;
    static constexpr int kHalf = kOctaves * kCellsPerOctave + 1;  // points per half
    static constexpr int kPerShape = 2 * kHalf;
    static constexpr int kMaxN = 32;  // shapes k, 2k, …, 32k

    double shapeStep() const { return k_; }
    // The standard Gamma(N·k) quantile at the word's u, 1 ≤ N ≤ kMaxN.
    float quantile(int n, std::uint32_t word) const noexcept;
    // Exact u of a word as above (for tests and the documentation of the mapping).
    static double uniformOf(std::uint32_t word) noexcept;
    // The table: shape N's points from data() + (N − 1)·kPerShape, lower half then upper half,
    // and one spare entry at the end (the interpolation reads the point after t = 1).
    const float* data() const { return table_.get(); }

    explicit GammaTable(double k);

  private:
    double k_;
    std::unique_ptr<float[]> table_;
};

// The tables already built, by shape step k: the MCP stages of every chain made with one cache
// share the table of their k (one build, ~0.1 s, and 0.5 MB, per k). Owned by whoever creates
// the chains (the runtime holds one for the process, a test its own) and kept as long as it
// lives; setup only, not for the frame loop.
class GammaTableCache {
  public:
    // The tables for shapes N·k, N = 1 … kMaxN (k > 0), built on the first request for this k.
    // Safe to call from several threads.
    std::shared_ptr<const GammaTable> forShapeStep(double k);

  private:
    std::mutex mutex_;
    std::map<double, std::shared_ptr<const GammaTable>> tables_;
};

// Draws for m pixels: out[j] = θ·Q_{N·k}(u(words[j])) with N = n[j] a whole number of
// photoelectrons from 1 to kMaxN, 0 where N = 0, and −1 for any other N (more than kMaxN, or a
// fraction: the caller draws those otherwise). Vector code
// (x86-64 baseline, AVX2 and AVX-512 versions, the same bits in each).
void gammaTableDraws(const GammaTable& table, const float* n, const std::uint32_t* words,
                     float* out, int m, float theta) noexcept;

}  // namespace nvs
