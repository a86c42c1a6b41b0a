#include "sim/core/rng.h"

#include <algorithm>
#include <array>
#include <bit>
#include <cmath>
#include <cstring>

#include "sim/core/simd.h"
#include "sim/core/units.h"

// GCC contracts a·b + c into FMA by default in C++ wherever the target has FMA, as the
// AVX-512F versions of the bulk loops below do; contraction is off for this file so that every
// sample is the same on every CPU and in every version of a loop.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace nvs {

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

namespace {
// PTRS (Hörmann 1993, algorithm PTRS with the constants of his Table 1), for the single draws
// of the per-pixel samplers. PtrsShape and ptrsK are also what poissonRow's
// vector first attempt computes: the same operations, so the same bits.
struct PtrsShape {
    double b, a, vr;
};
inline __attribute__((always_inline)) PtrsShape ptrsShape(double mean) {
    const double b = 0.931 + 2.53 * std::sqrt(mean);
    return {b, -0.059 + 0.02483 * b, 0.9277 - 3.6224 / (b - 2.0)};
}
// k of a pair (u − ½ and us = ½ − |u|).
inline __attribute__((always_inline)) double ptrsK(const PtrsShape& c, double mean, double u,
                                                   double us) {
    return std::floor((2.0 * c.a / us + c.b) * u + mean + 0.43);
}
// The draw from its first pair (u − ½, v); nextPair(u, v) gives the next. The logs that only
// the slow acceptance test needs are taken when it is first reached (in ~10 % of draws), so
// the common case costs a square root and two divisions.
template <class NextPair>
double ptrsDraw(double mean, double u, double v, NextPair&& nextPair) {
    const PtrsShape c = ptrsShape(mean);
    double invalpha = 0.0, loglam = 0.0;
    bool logs = false;
    for (;;) {
        const double us = 0.5 - std::fabs(u);
        const double k = ptrsK(c, mean, u, us);
        if (us >= 0.07 && v <= c.vr) return k;
        if (!(k < 0.0 || (us < 0.013 && v > us))) {
            if (!logs) {
                invalpha = 1.1239 + 1.1328 / (c.b - 3.4);
                loglam = std::log(mean);
                logs = true;
            }
            if (std::log(v) + std::log(invalpha) - std::log(c.a / (us * us) + c.b) <=
                -mean + k * loglam - logFactorial(k)) {
                return k;
            }
        }
        nextPair(u, v);
    }
}
}  // namespace

}  // namespace nvs

// ---- Per-pixel noise words: sim/core/philox.cpp ----------------------------------------------

namespace nvs {

namespace {

// ln x for normal positive floats (Cephes logf: x = 2^e·m, m ∈ [√½, √2), ln m by a degree-9
// polynomial in m − 1; relative error ~1e-7). Branch-free so that loops over it vectorise.
inline float logPositive(float x) {
    // Integer split: subtracting the bits of √½ and shifting gives e with m = x/2^e in
    // [√½, √2), with no branch.
    const std::int32_t bits = std::bit_cast<std::int32_t>(x);
    const std::int32_t e = (bits - 0x3F3504F3) >> 23;
    const float f = std::bit_cast<float>(
                        bits - static_cast<std::int32_t>(static_cast<std::uint32_t>(e) << 23)) -
                    1.0f;
    const float z = f * f;
    float p = 7.0376836292e-2f;
    p = p * f - 1.1514610310e-1f;
    p = p * f + 1.1676998740e-1f;
    p = p * f - 1.2420140846e-1f;
    p = p * f + 1.4249322787e-1f;
    p = p * f - 1.6668057665e-1f;
    p = p * f + 2.0000714765e-1f;
    p = p * f - 2.4999993993e-1f;
    p = p * f + 3.3333331174e-1f;
    const float fe = static_cast<float>(e);
    float y = p * f * z;
    y += -2.12194440e-4f * fe;
    y += -0.5f * z;
    return f + y + 0.693359375f * fe;
}

// Two-sided tail probability q ∈ (0, 1) from the low 31 bits, and w = −ln(q(2 − q)).
inline float tailProbability(std::uint32_t word) {
    return (static_cast<float>(static_cast<std::int32_t>(word & 0x7FFFFFFFu)) + 0.5f) * 0x1.0p-31f;
}

// Giles (2010) central branch, w < 5: erfinv(x) = x·p(w − 2.5).
inline float erfinvCentral(float x, float w) {
    w -= 2.5f;
    float p = 2.81022636e-08f;
    p = 3.43273939e-07f + p * w;
    p = -3.5233877e-06f + p * w;
    p = -4.39150654e-06f + p * w;
    p = 0.00021858087f + p * w;
    p = -0.00125372503f + p * w;
    p = -0.00417768164f + p * w;
    p = 0.246640727f + p * w;
    p = 1.50140941f + p * w;
    return p * x;
}

// Tail branch, w ≥ 5: erfinv(x) = x·p(√w − 3).
inline float erfinvTail(float x, float w) {
    w = std::sqrt(w) - 3.0f;
    float p = -0.000200214257f;
    p = 0.000100950558f + p * w;
    p = 0.00134934322f + p * w;
    p = -0.00367342844f + p * w;
    p = 0.00573950773f + p * w;
    p = -0.0076224613f + p * w;
    p = 0.00943887047f + p * w;
    p = 1.00167406f + p * w;
    p = 2.83297682f + p * w;
    return p * x;
}

constexpr float kSqrt2f = 1.41421356f;

}  // namespace

float normalFromWord(std::uint32_t word) noexcept {
    const float q = tailProbability(word);
    const float w = -logPositive(q * (2.0f - q));
    const float x = 1.0f - q;
    const float a = kSqrt2f * (w < 5.0f ? erfinvCentral(x, w) : erfinvTail(x, w));
    return (word & 0x80000000u) ? -a : a;
}

// Loops over fixed chunks of kChunk elements vectorise at -O2 (GCC's "very cheap" cost model
// wants a trip count that is a known multiple of the vector width); the rest runs scalar.
constexpr int kChunk = 16;

namespace {
inline float normalCentral(std::uint32_t word) {
    const float q = tailProbability(word);
    const float w = -logPositive(q * (2.0f - q));
    const float a = kSqrt2f * erfinvCentral(1.0f - q, w);
    return std::bit_cast<float>(std::bit_cast<std::uint32_t>(a) ^ (word & 0x80000000u));
}
}  // namespace

NVS_SIMD_CLONES void normalsFromWords(const std::uint32_t* __restrict words, float* __restrict z,
                                      int n) noexcept {
    // Pass 1 (vector): every word by the central branch.
    int i = 0;
    for (; i + kChunk <= n; i += kChunk) {
        const std::uint32_t* wc = words + i;
        float* zc = z + i;
        for (int j = 0; j < kChunk; ++j)
            zc[j] = normalCentral(wc[j]);
    }
    for (; i < n; ++i)
        z[i] = normalCentral(words[i]);
    // Pass 2: the tail words (q < 0.0034, w ≥ 5) again, by the tail branch. w ≥ 5 means
    // q(2 − q) ≤ e⁻⁵; testing the word against a threshold a little above that keeps the
    // branch choice identical to normalFromWord's.
    // Chunks without a tail word (95 %) are passed over after one vector test.
    constexpr std::uint32_t kTailBits = 7400000u;  // q = 0.00345 > q(w = 5) = 0.003375
    for (i = 0; i < n; i += kChunk) {
        const int m = std::min(kChunk, n - i);
        int tail = 0;
        if (m == kChunk) {
            for (int j = 0; j < kChunk; ++j)
                tail |= static_cast<int>((words[i + j] & 0x7FFFFFFFu) < kTailBits);
        } else {
            tail = 1;
        }
        if (!tail) continue;
        for (int j = 0; j < m; ++j) {
            if ((words[i + j] & 0x7FFFFFFFu) < kTailBits) z[i + j] = normalFromWord(words[i + j]);
        }
    }
}

namespace {
// kInvK[j] = 1/(j + 2): step j of the inversion turns P(N = j + 1) into
// P(N = j + 2) = P(N = j + 1)·m/(j + 2), computed as p·(m·kInvK[j]); past the table the scalar
// continuation divides (those k are so rare that the cost does not matter).
constexpr int kInvTable = 64;
constexpr std::array<double, kInvTable> kInvK = [] {
    std::array<double, kInvTable> t{};
    for (int j = 0; j < kInvTable; ++j)
        t[static_cast<std::size_t>(j)] = 1.0 / static_cast<double>(j + 2);
    return t;
}();

// The scalar continuation of the inversion from state (s, p, k): k counts the S(j) above u,
// s = S(k), p = P(N = k + 1). Used for whole draws too, so that a draw is the same whether
// its first steps ran in the vector pass or here.
double poissonInversionFrom(double mean, double u, double s, double p, double k) {
    while (u < s && k < mean + 60.0) {
        k += 1.0;
        s -= p;
        const int j = static_cast<int>(k) - 1;
        p = j < kInvTable ? p * (mean * kInvK[static_cast<std::size_t>(j)])
                          : p * (mean / (k + 1.0));
    }
    return k;
}
}  // namespace

// (The vector types below are only used inside this file and always inlined, so the -Wpsabi
// note on passing 64-byte vectors between functions compiled for different targets does not
// apply.)
#pragma GCC diagnostic ignored "-Wpsabi"
#define NVS_INLINE __attribute__((always_inline)) inline

void poissonStart(double m, double& s0, double& p1) noexcept {
    // e^(−m) = 2^n·(1 + E) with n = round(−m/ln 2), r = −m − n·ln 2 ∈ [−0.347, 0.347] (Cody and
    // Waite's two-part ln 2, whose high part has 11 trailing zero bits so n·ln2_hi is exact for
    // |n| < 2048), and E = e^r − 1 = r(1 + r/2(1 + r/3(1 + …))) to r^15/15! (< 2e-18 relative
    // at |r| = 0.347). Then S(0) = 1 − e^(−m) is −E when n = 0 (no cancellation for small m)
    // and 1 − e^(−m) otherwise (e^(−m) < 0.71 there). Plain IEEE double operations only: the
    // same bits on every CPU.
    constexpr double kInvLn2 = 1.4426950408889634;
    constexpr double kLn2Hi = 0.693147180369123816490;     // 0x3FE62E42FEE00000
    constexpr double kLn2Lo = 1.90821492927058770002e-10;  // ln 2 − kLn2Hi
    constexpr double kShifter = 0x1.8p52;                  // adding it rounds to an integer
    const double x = -m;
    const double t = x * kInvLn2 + kShifter;
    const double n = t - kShifter;
    const double r = (x - n * kLn2Hi) - n * kLn2Lo;
    double e = 1.0 + r * (1.0 / 15.0);
    e = 1.0 + r * (1.0 / 14.0) * e;
    e = 1.0 + r * (1.0 / 13.0) * e;
    e = 1.0 + r * (1.0 / 12.0) * e;
    e = 1.0 + r * (1.0 / 11.0) * e;
    e = 1.0 + r * (1.0 / 10.0) * e;
    e = 1.0 + r * (1.0 / 9.0) * e;
    e = 1.0 + r * (1.0 / 8.0) * e;
    e = 1.0 + r * (1.0 / 7.0) * e;
    e = 1.0 + r * (1.0 / 6.0) * e;
    e = 1.0 + r * (1.0 / 5.0) * e;
    e = 1.0 + r * (1.0 / 4.0) * e;
    e = 1.0 + r * (1.0 / 3.0) * e;
    e = 1.0 + r * 0.5 * e;
    const double em1 = r * e;  // e^r − 1
    // 2^n from its bits: n ∈ [−47, 0] for m ∈ (0, 32].
    const auto ni = std::bit_cast<std::int64_t>(t) - std::bit_cast<std::int64_t>(kShifter);
    const double scale = std::bit_cast<double>((ni + 1023) << 52);
    const double expNeg = scale + scale * em1;
    s0 = n == 0.0 ? -em1 : 1.0 - expNeg;
    p1 = m * expNeg;
}

namespace {
// Means below this are drawn by inversion, the others by PTRS. PTRS accepts at its first, cheap
// test only 35–65 % of draws for means between 10 (where it becomes valid) and 100, and the rest
// take five logarithms; the inversion runs ~m steps of four operations, in 16-lane vectors
// (poissonRow). Up to 32 the inversion is the cheaper.
constexpr double kInversionBelow = 32.0;
constexpr float kInversionBelowF = 32.0f;

// PTRS from its first pair (u − ½, v), further pairs from the pixel's stream.
double poissonPtrsFrom(double mean, double u, double v, PixelStream& more) noexcept {
    return ptrsDraw(mean, u, v, [&more](double& u2, double& v2) {
        u2 = more.uniform() - 0.5;
        v2 = more.uniform();
    });
}

double poissonInversion(double mean, std::uint32_t word) noexcept {
    double s0 = 0.0, p1 = 0.0;
    poissonStart(mean, s0, p1);
    return poissonInversionFrom(mean, uniformFromWord(word), s0, p1, 0.0);
}
}  // namespace

double poissonFromWord(double mean, std::uint32_t word, PixelStream& more) noexcept {
    if (!(mean > 0.0)) return 0.0;
    if (mean < kInversionBelow) return poissonInversion(mean, word);
    const double u = uniformFromWord(word) - 0.5;
    return poissonPtrsFrom(mean, u, more.uniform(), more);
}

namespace {
// Sixteen floats as one value: GCC's vector extensions, lowered to whatever the clone's target
// has (one AVX-512 register, two AVX2 or four SSE2 ones), lane by lane the same IEEE operations.
using V16f = float __attribute__((vector_size(64)));
using V16i = std::int32_t __attribute__((vector_size(64)));

// The inversion's vector pass in single precision with a certainty margin. Single precision
// makes S(j) within 1.6e-5 of the double recurrence's value for j < kFloatSteps = 64 and m < 32:
// e^(−m) to 2.4e-7 relative (below), then at most three roundings of 6e-8 relative per step in
// P(N = j + 1) (so ≤ 1.2e-5 relative, and the P sum to ≤ 1), and one of 6e-8 absolute per
// subtraction in S (≤ 3.8e-6 over 64 steps). A comparison u < S(j)
// whose two sides are more than kCertainMargin apart is therefore decided as the double
// recurrence decides it; a draw whose deciding comparisons are closer than that (~1e-4 of
// them), or still counting after kFloatSteps, is made again in double. So the draws are
// bit-identical to poissonFromWord's, at twice the vector width.
constexpr int kFloatSteps = 64;
constexpr float kCertainMargin = 0x1.0p-14f;  // 6.1e-5, nearly four times the bound above
constexpr std::array<float, kFloatSteps> kInvKf = [] {
    std::array<float, kFloatSteps> t{};
    for (int j = 0; j < kFloatSteps; ++j)
        t[static_cast<std::size_t>(j)] = 1.0f / static_cast<float>(j + 2);
    return t;
}();

// The bits of one vector as another of the same size. (Not std::bit_cast: GCC 12 with
// -fsanitize=undefined at -O0 reports a null load inside std::bit_cast of a vector type in a
// target_clones function, a false positive that stops the debug-asan tests.)
template <class To, class From>
NVS_INLINE To vectorBits(const From& from) {
    static_assert(sizeof(To) == sizeof(From));
    To to;
    std::memcpy(&to, &from, sizeof to);
    return to;
}

// Whether any lane is > 0: max-folded in halves.
NVS_INLINE bool anyPositive(V16f x) {
    using V8f = float __attribute__((vector_size(32)));
    using V4f = float __attribute__((vector_size(16)));
    const V8f a = __builtin_shufflevector(x, x, 0, 1, 2, 3, 4, 5, 6, 7);
    const V8f b = __builtin_shufflevector(x, x, 8, 9, 10, 11, 12, 13, 14, 15);
    const V8f x8 = a > b ? a : b;
    const V4f c = __builtin_shufflevector(x8, x8, 0, 1, 2, 3);
    const V4f d = __builtin_shufflevector(x8, x8, 4, 5, 6, 7);
    const V4f x4 = c > d ? c : d;
    return std::max(std::max(x4[0], x4[1]), std::max(x4[2], x4[3])) > 0.0f;
}

// u of a word in single precision, within 1e-7 of uniformFromWord's (pass 1's and the
// inversion's comparisons allow for it).
NVS_INLINE float uniformFloat(std::uint32_t w) {
    return static_cast<float>(static_cast<std::int32_t>(w >> 1)) * 0x1.0p-31f;
}

// The inversion for 16·G draws at once (G 16-lane vectors, whose steps overlap; one early-exit
// test for all of them; kInvLanes = 64 where there are many): k[i] for means m[i] in (0, 32),
// u[i] as float, or −1 where the double path must decide.
constexpr int kInvGroup = 4;
constexpr int kInvLanes = 16 * kInvGroup;
template <int G = kInvGroup>
NVS_INLINE void poissonInversionF(const float* __restrict mIn, const float* __restrict uIn,
                                  float* __restrict kOut) noexcept {
    V16f m[G], u[G], s[G], p[G], k[G], hi[G], lo[G];
#pragma GCC unroll 8
    for (int g = 0; g < G; ++g) {
        std::memcpy(&m[g], mIn + 16 * g, sizeof(V16f));
        std::memcpy(&u[g], uIn + 16 * g, sizeof(V16f));
        // e^(−m) = 2^n(1 + E): n = round(−m/ln 2) ∈ [−47, 0], r = −m − n·ln 2 (Cody–Waite: the
        // high part 355/512 has 9 bits, so n·ln2_hi is exact) and E = e^r − 1 to r⁸/8!
        // (< 6e-9 at |r| ≤ 0.347).
        const V16f x = -m[g];
        const V16f t = x * 1.44269504f + 0x1.8p23f;
        const V16f n = t - 0x1.8p23f;
        const V16f r = (x - n * 0.693359375f) - n * -2.12194440e-4f;
        V16f e = 1.0f + r * (1.0f / 7.0f);
        e = 1.0f + r * (1.0f / 6.0f) * e;
        e = 1.0f + r * (1.0f / 5.0f) * e;
        e = 1.0f + r * (1.0f / 4.0f) * e;
        e = 1.0f + r * (1.0f / 3.0f) * e;
        e = 1.0f + r * 0.5f * e;
        const V16f em1 = r * e;
        const V16i ni = vectorBits<V16i>(t) - std::bit_cast<std::int32_t>(0x1.8p23f);
        const V16f scale = vectorBits<V16f>((ni + 127) << 23);
        const V16f expNeg = scale + scale * em1;
        s[g] = n == 0.0f ? -em1 : 1.0f - expNeg;
        p[g] = m[g] * expNeg;
        k[g] = m[g] * 0.0f;
        hi[g] = m[g] * 0.0f + 3.0e38f;  // S(k − 1), the last S above u (none yet)
        lo[g] = s[g];                   // S(k), the candidate for the first S not above u
    }
    for (int step = 0; step < kFloatSteps;) {
        for (int q = 0; q < 4; ++q, ++step) {
            const float inv = kInvKf[static_cast<std::size_t>(step)];
#pragma GCC unroll 8
            for (int g = 0; g < G; ++g) {
                const V16i above = u[g] < s[g];
                const V16f next = s[g] - p[g];
                k[g] = above ? k[g] + 1.0f : k[g];
                hi[g] = above ? s[g] : hi[g];
                lo[g] = above ? next : lo[g];
                s[g] = next;
                p[g] = p[g] * (m[g] * inv);
            }
        }
        // Still counting anywhere: max(s − u) > 0.
        V16f gap = s[0] - u[0];
#pragma GCC unroll 8
        for (int g = 1; g < G; ++g) {
            const V16f d = s[g] - u[g];
            gap = d > gap ? d : gap;
        }
        if (!anyPositive(gap)) break;
    }
    // Certain where u is at least the margin below S(k − 1) and above S(k) (every earlier S is
    // above S(k − 1)), and the count has ended.
#pragma GCC unroll 8
    for (int g = 0; g < G; ++g) {
        // Unsure where u < s (still counting), hi − u < margin or u − lo < margin: the largest
        // of s − u, margin − (hi − u) and margin − (u − lo) is > 0. (One comparison per select:
        // GCC 12 lowers a select on several AVX-512 comparisons combined lane by lane.)
        const V16f a = s[g] - u[g];
        const V16f b = kCertainMargin - (hi[g] - u[g]);
        const V16f c = kCertainMargin - (u[g] - lo[g]);
        V16f worst = a > b ? a : b;
        worst = c > worst ? c : worst;
        const V16f out = worst > 0.0f ? m[g] * 0.0f - 1.0f : k[g];
        std::memcpy(kOut + 16 * g, &out, sizeof out);
    }
}
}  // namespace

NVS_SIMD_CLONES void poissonRow(const float* __restrict mean, const std::uint32_t* __restrict words,
                                float* __restrict out, int n, const PixelRng& rng, std::uint32_t x0,
                                std::uint32_t y) noexcept {
    // Blocks of kBlock pixels: pass 1 (vector) settles the certain zeros; pass 2 runs the
    // inversion for the means below 32 in single-precision vectors (poissonInversionF), over
    // the whole block where most pixels are open, else over the open ones gathered; pass 3
    // makes in double the few inversions pass 2 left uncertain, and draws the means of 32 and
    // more by PTRS, its first attempt in double vectors with v from the pixel's stream head
    // (made in bulk). Every draw equals poissonFromWord's.
    constexpr int kBlock = 256;
    int cand[kBlock];
    int big[kBlock];
    alignas(64) float cm[kBlock], cu[kBlock], ck[kBlock];
    alignas(64) double bm[kBlock], bu[kBlock], bv[kBlock], bk[kBlock];
    alignas(64) std::uint32_t bx[kBlock], heads[4 * kBlock];
    // PTRS for the listed means of 32 and more (and NaN) of the block at b: the first attempt
    // (vector) as poissonPtrsFrom makes it, −1 where it does not accept; then the rest.
    // (Inlined, so that it is compiled for each clone's target.)
    const auto ptrsBlock = [&](int b, int nBig) __attribute__((always_inline)) {
        if (nBig == 0) return;
        const float* __restrict mb = mean + b;
        const std::uint32_t* __restrict wb = words + b;
        float* __restrict ob = out + b;
        // PTRS's first attempt (vector), as poissonPtrsFrom makes it: −1 where it does not
        // accept (or the mean is NaN).
        for (int c = 0; c < nBig; ++c)
            bx[c] = x0 + static_cast<std::uint32_t>(b + big[c]);
        rng.streamHeads(y, bx, nBig, heads);
        const int bigPadded = (nBig + kChunk - 1) / kChunk * kChunk;
        for (int c = 0; c < bigPadded; ++c) {
            const bool real = c < nBig;
            bm[c] = real ? static_cast<double>(mb[big[c]]) : kInversionBelow;
            bu[c] = real ? uniformFromWord(wb[big[c]]) - 0.5 : 0.0;
            bv[c] = real ? uniformFromWord(heads[4 * c]) : 0.5;
        }
        for (int c = 0; c < bigPadded; c += kChunk) {
            const double* mc = bm + c;
            const double* uc = bu + c;
            const double* vc = bv + c;
            double* kc = bk + c;
            for (int l = 0; l < kChunk; ++l) {
                const PtrsShape shape = ptrsShape(mc[l]);
                const double us = 0.5 - std::fabs(uc[l]);
                const double k = ptrsK(shape, mc[l], uc[l], us);
                kc[l] = ((us >= 0.07) & (vc[l] <= shape.vr)) ? k : -1.0;
            }
        }
        for (int c = 0; c < nBig; ++c) {
            const int i = big[c];
            if (bk[c] >= 0.0) {
                ob[i] = static_cast<float>(bk[c]);
                continue;
            }
            const double m = static_cast<double>(mb[i]);
            if (!(m > 0.0)) {
                ob[i] = 0.0f;
                continue;
            }
            PixelStream more(rng.pixelStream(bx[c], y), heads + 4 * c, 1);
            ob[i] = static_cast<float>(poissonPtrsFrom(m, bu[c], bv[c], more));
        }
    };
    for (int b = 0; b < n; b += kBlock) {
        const int nb = std::min(kBlock, n - b);
        const float* __restrict mb = mean + b;
        const std::uint32_t* __restrict wb = words + b;
        float* __restrict ob = out + b;
        // Pass 1 (vector): 0 where u ≥ m certainly, −1 where the exact sampler must decide.
        // u_f = ⌊w/2⌋·2⁻³¹ rounded to float is at most u·(1 + 2⁻²⁴); the margin 2⁻²⁰ covers
        // it. m ≤ 0 gives 0 here (u_f ≥ 0); NaN fails the test and gets 0 below.
        int open = 0;
        int j = 0;
        for (; j + kChunk <= nb; j += kChunk) {
            for (int l = 0; l < kChunk; ++l) {
                const bool zero = uniformFloat(wb[j + l]) >= mb[j + l] * (1.0f + 0x1.0p-20f);
                ob[j + l] = zero ? 0.0f : -1.0f;
                open += zero ? 0 : 1;
            }
        }
        for (; j < nb; ++j) {
            const bool zero = uniformFloat(wb[j]) >= mb[j] * (1.0f + 0x1.0p-20f);
            ob[j] = zero ? 0.0f : -1.0f;
            open += zero ? 0 : 1;
        }
        if (open == 0) continue;
        // Pass 2 (vector): the inversion for open means in (0, 32). Its result k ≥ 0 is the
        // draw; −1 (not certain) stays open for pass 3, as do the means of 32 and more.
        if (2 * open > nb) {
            // Most are open: the whole block (the others' lanes compute a harmless mean of 1
            // and are not written).
            for (j = 0; j < nb; j += kInvLanes) {
                const int len = std::min(kInvLanes, nb - j);
                alignas(64) float mt[kInvLanes], ut[kInvLanes], kt[kInvLanes];
                if (len == kInvLanes) {
                    for (int l = 0; l < kInvLanes; ++l) {
                        const float mm = mb[j + l];
                        mt[l] = mm > 0.0f && mm < kInversionBelowF ? mm : 1.0f;
                        ut[l] = uniformFloat(wb[j + l]);
                    }
                } else {
                    for (int l = 0; l < kInvLanes; ++l) {
                        const float mm = l < len ? mb[j + l] : 1.0f;
                        mt[l] = mm > 0.0f && mm < kInversionBelowF ? mm : 1.0f;
                        ut[l] = l < len ? uniformFloat(wb[j + l]) : 0.5f;
                    }
                }
                poissonInversionF(mt, ut, kt);
                if (len == kInvLanes) {
                    // A plain loop of a fixed length, which GCC vectorises with mask
                    // registers. (The same selects written on V16f values, nested, were
                    // lowered by GCC 12 lane by lane into scalar compares: a third of this
                    // function's time.) A NaN mean keeps o.
                    for (int l = 0; l < kInvLanes; ++l) {
                        const float mm = mb[j + l];
                        const float o = ob[j + l];
                        const bool take = (o < 0.0f) & (mm > 0.0f) & (mm < kInversionBelowF);
                        ob[j + l] = take ? kt[l] : o;
                    }
                } else {
                    for (int l = 0; l < len; ++l) {
                        const float mm = mb[j + l];
                        const bool small = (mm > 0.0f) & (mm < kInversionBelowF);
                        ob[j + l] = ((ob[j + l] < 0.0f) & small) ? kt[l] : ob[j + l];
                    }
                }
            }
        } else {
            // Few are open: their positions first (one cheap pass), then their means and u
            // gathered for the inversion, and the large means listed apart.
            int nOpen = 0;
            for (j = 0; j < nb; ++j) {
                cand[nOpen] = j;
                nOpen += ob[j] < 0.0f ? 1 : 0;
            }
            int listed = 0, nBig = 0;
            for (int c = 0; c < nOpen; ++c) {
                const int i = cand[c];  // listed ≤ c: the small ones are moved down in place
                const float m = mb[i];
                const bool small = (m > 0.0f) & (m < kInversionBelowF);
                cand[listed] = i;
                cm[listed] = m;
                cu[listed] = uniformFloat(wb[i]);
                listed += small ? 1 : 0;
                big[nBig] = i;
                nBig += small ? 0 : 1;
            }
            const int listedPadded = (listed + 15) / 16 * 16;
            for (j = listed; j < listedPadded; ++j) {  // padding lanes: a harmless mean of 1
                cm[j] = 1.0f;
                cu[j] = 0.5f;
            }
            for (j = 0; j + kInvLanes <= listedPadded; j += kInvLanes)
                poissonInversionF(cm + j, cu + j, ck + j);
            for (; j < listedPadded; j += 16)
                poissonInversionF<1>(cm + j, cu + j, ck + j);
            for (int c = 0; c < listed; ++c) {
                const int i = cand[c];
                const float k = ck[c];
                ob[i] =
                    k >= 0.0f
                        ? k
                        : static_cast<float>(poissonInversion(static_cast<double>(mb[i]), wb[i]));
            }
            ptrsBlock(b, nBig);
            continue;
        }
        // Pass 3: the pixels still open (chunks with none are passed over after one vector
        // test): uncertain inversions again in double; means of 32 and more (and NaN) listed.
        int nBig = 0;
        for (j = 0; j < nb; j += 16) {
            const int m = std::min(16, nb - j);
            if (m == 16) {
                V16f o;
                std::memcpy(&o, ob + j, sizeof o);
                if (!anyPositive(-o)) continue;  // no lane below 0
            }
            for (int l = 0; l < m; ++l) {
                const int i = j + l;
                if (!(ob[i] < 0.0f)) continue;
                const float mm = mb[i];
                if (mm > 0.0f && mm < kInversionBelowF) {
                    ob[i] = static_cast<float>(poissonInversion(static_cast<double>(mm), wb[i]));
                } else {
                    big[nBig++] = i;
                }
            }
        }
        ptrsBlock(b, nBig);
    }
}

double gammaFromNormal(double shape, double scale, float z0, std::uint32_t u0,
                       PixelStream& more) noexcept {
    if (!(shape > 0.0)) return 0.0;
    if (shape < 1.0) {
        const double g = gammaFromNormal(shape + 1.0, 1.0, z0, u0, more);
        return scale * g * std::pow(more.uniform(), 1.0 / shape);
    }
    const double d = shape - 1.0 / 3.0;
    const double c = 1.0 / std::sqrt(9.0 * d);
    bool first = true;
    for (;;) {
        const double x = static_cast<double>(first ? z0 : normalFromWord(more.next()));
        const double u = first ? uniformFromWord(u0) : more.uniform();
        first = false;
        double v = 1.0 + c * x;
        if (v <= 0.0) continue;
        v = v * v * v;
        const double x2 = x * x;
        if (u < 1.0 - 0.0331 * x2 * x2) return scale * d * v;
        if (std::log(u) < 0.5 * x2 + d * (1.0 - v + std::log(v))) return scale * d * v;
    }
}

double gammaFromWords(double shape, double scale, std::uint32_t z0, std::uint32_t u0,
                      PixelStream& more) noexcept {
    if (!(shape > 0.0)) return 0.0;
    return gammaFromNormal(shape, scale, normalFromWord(z0), u0, more);
}

}  // namespace nvs
