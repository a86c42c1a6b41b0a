#pragma once
// Keyed, counter-based random numbers (docs/design.md §3).
//
// The noise of pixel (x, y) in frame k of stream s is a pure function of (seed, s, k, x, y),
// the same on any thread, in any order, with any tiling. The generator is Philox4x32-10
// (Salmon, Moraes, Dror & Shaw, "Parallel random numbers: as easy as 1, 2, 3", SC 2011).
//
// The distributions are exact samplers (no normal approximations):
//   poisson   inversion up to mean 32 (one word); above, PTRS, Hörmann (1993) "The
//             transformed rejection method for generating Poisson random variables" — exact,
//             O(1) (~2.3 uniforms) at any mean.
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
    Faults = 7,  // a rig channel's injected faults (rt/loop: dropped frames, stamp jitter)
};

// ---- Per-pixel noise words (Philox4x32-10) ---------------------------------------------------
//
// Image noise needs a word or two per pixel per stage, hundreds of thousands per field, so it
// is drawn in bulk: PixelRng(key, frame).rowWords(y, plane, b0, nb, out) fills out with the
// 4·nb words of blocks b0 … b0+nb−1 of row y. Block b is Philox4x32-10 (Salmon et al. 2011;
// the same function as r123::Philox4x32, checked in tests) with key = seed and counter
//   (plane·2²⁴ + b, y, frame mod 2³², stream·2¹⁶ + (frame / 2³²) mod 2¹⁶),
// and a caller using W words per pixel gives pixel x the words x·W … x·W+W−1 of its row. So a
// pixel's word is a pure function of (seed, stream, frame, x, y, plane), however rows are
// split into chunks or threads. Samplers that need more words than that (rejection steps,
// distribution tails) take them from pixelStream(x, y): a sequence keyed by the pixel alone
// (counter word 0 has its top bit set, so it never meets a row block). Limits: b < 2²⁴,
// plane < 128, x < 2²³, frames < 2⁴⁸; a pixel stream repeats after 1024 words.
//
// The words are made four blocks at a time in plain loops over lane arrays, which the
// compiler turns into SIMD code at -O2 without target flags.

class PixelStream {
  public:
    PixelStream(std::uint32_t k0, std::uint32_t k1, std::uint32_t c0, std::uint32_t c1,
                std::uint32_t c2, std::uint32_t c3) noexcept
        : key_{k0, k1}, ctr_{c0, c1, c2, c3} {}
    // The same sequence with its first block already made (PixelRng::streamHeads) and its
    // first `used` words (0 … 4) taken.
    PixelStream(const PixelStream& fresh, const std::uint32_t head[4], int used) noexcept;
    std::uint32_t next() noexcept;
    // Uniform on (0, 1) from one word: (w + 0.5)·2⁻³².
    double uniform() noexcept;

  private:
    std::uint32_t key_[2];
    std::uint32_t ctr_[4];
    std::uint32_t out_[4] = {0, 0, 0, 0};
    int used_ = 4;
};

class PixelRng {
  public:
    PixelRng(RngKey key, std::uint64_t frame) noexcept;
    PixelRng(std::uint64_t seed, RngStream stream, std::uint64_t frame) noexcept
        : PixelRng(RngKey{seed, static_cast<std::uint32_t>(stream)}, frame) {}
    // Writes 4·nBlocks words: blocks b0 … b0+nBlocks−1 of row y in `plane`.
    void rowWords(std::uint32_t y, std::uint32_t plane, std::uint32_t b0, int nBlocks,
                  std::uint32_t* out) const noexcept;
    // Block b of row y alone (the same four words rowWords gives), for sparse use.
    void block(std::uint32_t y, std::uint32_t plane, std::uint32_t b,
               std::uint32_t out[4]) const noexcept;
    // Blocks blocks[0] … blocks[n−1] of row y (any order, repeats allowed): 4·n words, the
    // same as block() gives one by one, made in bulk (for rows where few pixels draw).
    void blocksAt(std::uint32_t y, std::uint32_t plane, const std::uint32_t* blocks, int n,
                  std::uint32_t* out) const noexcept;
    PixelStream pixelStream(std::uint32_t x, std::uint32_t y) const noexcept;
    // The first block (four words) of pixelStream(xs[i], y) for each listed x, made in bulk:
    // for samplers whose first attempt needs one word more than a pixel's row words.
    void streamHeads(std::uint32_t y, const std::uint32_t* xs, int n,
                     std::uint32_t* out) const noexcept;

  private:
    std::uint32_t key_[2];
    std::uint32_t c2_;
    std::uint32_t c3_;
};

// One Philox4x32-10 block (exposed for tests against Random123).
void philox4x32Block(const std::uint32_t key[2], const std::uint32_t ctr[4],
                     std::uint32_t out[4]) noexcept;

// Uniform on (0, 1) from one word, (w + 0.5)·2⁻³².
inline double uniformFromWord(std::uint32_t w) {
    return (static_cast<double>(w) + 0.5) * 0x1.0p-32;
}

// Standard normals, one per word, by inversion in single precision: the top bit is the sign
// and the other 31 give the two-sided tail probability q = P(|Z| > |z|) ∈ (0, 1), so
// |z| = √2·erfinv(1 − q) keeps full float resolution in the tails (|z| up to 6.4). erfinv is
// Giles (2010), "Approximating the erfinv function" (GPU Computing Gems, single precision):
// relative error below 4e-7. Vector-friendly: one log and a polynomial per word, the rare
// tail branch (q < 0.34 %) patched in a second pass.
void normalsFromWords(const std::uint32_t* words, float* z, int n) noexcept;
float normalFromWord(std::uint32_t w) noexcept;

// Poisson(mean) from one word, exact to the word's 2⁻³² resolution: for mean < 32, inversion
// on the survival function S(k) = P(N > k): k is the first with u ≥ S(k), S(0) = P(N ≥ 1) =
// −expm1(−mean) and P(N = 1) from poissonStart; for mean ≥ 32, PTRS
// with the first u from the word and the rest from `more`.
double poissonFromWord(double mean, std::uint32_t word, PixelStream& more) noexcept;

// The inversion's start for 0 < m ≤ 32: s0 = −expm1(−m) = P(N ≥ 1) and p1 = m·e^(−m) = P(N = 1),
// within a few ulp of libm's, by plain double arithmetic (libm's expm1 and exp were most of the
// cost of a night scene's photocathode). Exposed for tests.
void poissonStart(double m, double& s0, double& p1) noexcept;

// Poisson draws for a row: out[i] ~ Poisson(mean[i]) with word[i], pixel x0 + i of row y; each
// equals poissonFromWord's. Most pixels of a dark scene draw 0: since P(N ≥ 1) = 1 − e^(−m) < m,
// u ≥ m settles k = 0 in a vector pass; the others (probability ≈ m) run the inversion in
// single-precision vectors, decided there wherever single precision is certain to decide as
// double does (all but ~1e-4 of draws; the rest again in double), and PTRS's first attempt in
// double vectors. Negative, NaN or zero means give 0.
void poissonRow(const float* mean, const std::uint32_t* words, float* out, int n,
                const PixelRng& rng, std::uint32_t x0, std::uint32_t y) noexcept;

// Gamma(shape, scale) by Marsaglia & Tsang (2000), first attempt from the words z0 (normal)
// and u0 (uniform), further attempts from `more`; shape < 1 by Gamma(shape + 1)·U^(1/shape).
double gammaFromWords(double shape, double scale, std::uint32_t z0, std::uint32_t u0,
                      PixelStream& more) noexcept;
// The same draw with the first normal given (normalFromWord(z0), or normalsFromWords' value
// for that word, which is the same): for callers that made the normals in a vector pass.
double gammaFromNormal(double shape, double scale, float z0, std::uint32_t u0,
                       PixelStream& more) noexcept;

// ln(k!) for k ≥ 0: a table below 16, Stirling's series above (error < 1e-12). Exposed for
// tests.
double logFactorial(double k);

}  // namespace nvs
