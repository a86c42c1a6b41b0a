#include "sim/core/gamma_table.h"

#include <gsl/gsl_cdf.h>
#include <gsl/gsl_errno.h>

#include <bit>
#if defined(__x86_64__)
#include <immintrin.h>
#endif
#include <cmath>
#include <cstring>
#include <map>
#include <mutex>

#include "sim/core/cpu_isa.h"
#include "sim/core/error.h"
#include "sim/core/simd.h"

// Single precision throughout the draws, no FMA contraction (see rng.cpp): the same bits in
// every vector version and on every CPU.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace nvs {

namespace {

// t of table point g = o·64 + c (g = 2048: t = 1), as a double.
double tOfPoint(int g) {
    const int o = g / GammaTable::kCellsPerOctave;
    const int c = g % GammaTable::kCellsPerOctave;
    return std::ldexp(1.0 + c / static_cast<double>(GammaTable::kCellsPerOctave), o - 1 - 31);
}

}  // namespace

GammaTable::GammaTable(double k)
    : k_(k), table_(new float[static_cast<std::size_t>(kMaxN) * kPerShape + 1]) {
    if (!(k > 0.0) || !std::isfinite(k)) throw SetupError("GammaTable: shape step must be > 0");
    // GSL reports failures through its error handler (abort by default); the inverses below
    // are checked by value instead.
    gsl_error_handler_t* old = gsl_set_error_handler_off();
    float* t = table_.get();
    for (int n = 1; n <= kMaxN; ++n) {
        const double a = n * k;
        float* lo = t + static_cast<std::ptrdiff_t>(n - 1) * kPerShape;
        float* hi = lo + kHalf;
        for (int g = 0; g < kHalf; ++g) {
            const double p = 0.5 * tOfPoint(g);  // u = p (lower half) or 1 − p (upper half)
            double ql = gsl_cdf_gamma_Pinv(p, a, 1.0);
            double qh = gsl_cdf_gamma_Qinv(p, a, 1.0);
            if (g == kHalf - 1) ql = qh = 0.5 * (ql + qh);  // the median, where the halves meet
            if (!(ql >= 0.0) || !std::isfinite(ql) || !(qh >= ql) || !std::isfinite(qh)) {
                gsl_set_error_handler(old);
                throw SetupError("GammaTable: GSL could not invert Gamma(" + std::to_string(a) +
                                 ") at " + std::to_string(p));
            }
            lo[g] = static_cast<float>(ql);
            hi[g] = static_cast<float>(qh);
        }
    }
    t[static_cast<std::size_t>(kMaxN) * kPerShape] =
        t[static_cast<std::size_t>(kMaxN) * kPerShape - 1];
    gsl_set_error_handler(old);
}

std::shared_ptr<const GammaTable> GammaTableCache::forShapeStep(double k) {
    const std::lock_guard<std::mutex> lock(mutex_);
    auto& slot = tables_[k];
    if (!slot) slot = std::make_shared<const GammaTable>(k);
    return slot;
}

double GammaTable::uniformOf(std::uint32_t word) noexcept {
    const double t = (static_cast<double>(word & 0x7FFFFFFFu) + 0.5) * 0x1.0p-31;
    return (word >> 31) ? 1.0 - 0.5 * t : 0.5 * t;
}

namespace {
// Table index and interpolation fraction of a word within one shape's points (gammaTableDraws
// does the same, sixteen at a time).
inline __attribute__((always_inline)) void locate(std::uint32_t word, std::int32_t& index,
                                                  float& frac) {
    const float tf =
        static_cast<float>(static_cast<std::int32_t>(word & 0x7FFFFFFFu)) + 0.5f;  // ∈ [½, 2³¹]
    const std::uint32_t bits = std::bit_cast<std::uint32_t>(tf);
    const std::int32_t octave = static_cast<std::int32_t>(bits >> 23) - 126;
    const std::int32_t cell = static_cast<std::int32_t>((bits & 0x7FFFFFu) >> 17);
    frac = static_cast<float>(static_cast<std::int32_t>(bits & 0x1FFFFu)) * 0x1.0p-17f;
    index = static_cast<std::int32_t>(word >> 31) * GammaTable::kHalf +
            octave * GammaTable::kCellsPerOctave + cell;
}
}  // namespace

float GammaTable::quantile(int n, std::uint32_t word) const noexcept {
    std::int32_t i = 0;
    float f = 0.0f;
    locate(word, i, f);
    const float* s = table_.get() + static_cast<std::ptrdiff_t>(n - 1) * kPerShape;
    return s[i] + f * (s[i + 1] - s[i]);
}

static_assert(GammaTable::kMaxN == 32, "gammaTableDraws clamps N to 32");
#pragma GCC diagnostic ignored "-Wpsabi"  // vector types only inside one function

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(NVS_SINGLE_TARGET)
#define NVS_GAMMA_AVX512 1
// GCC 12's AVX-512 intrinsic headers trip -Wmaybe-uninitialized on their own "undefined"
// pass-through operands (a known false positive; as in rng.cpp).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
namespace {

// gammaTableDraws for whole vectors in AVX-512, written out for its gathers (GCC's vectoriser
// does not gather under its generic tuning, and the sixteen scalar loads and lane extractions
// per table read were most of the cost). The same IEEE single-precision operations as the
// generic version below, in the same order: the same bits.
__attribute__((target("avx512f"))) void gammaDrawsAvx512(const float* __restrict t,
                                                         const float* __restrict n,
                                                         const std::uint32_t* __restrict words,
                                                         float* __restrict out, int m,
                                                         float theta) noexcept {
    const __m512 one = _mm512_set1_ps(1.0f);
    const __m512 maxN = _mm512_set1_ps(32.0f);
    const __m512 half = _mm512_set1_ps(0.5f);
    const __m512 fracScale = _mm512_set1_ps(0x1.0p-17f);
    const __m512 th = _mm512_set1_ps(theta);
    const __m512 minusOne = _mm512_set1_ps(-1.0f);
    const __m512i low31 = _mm512_set1_epi32(0x7FFFFFFF);
    const __m512i evenWords =
        _mm512_set_epi32(30, 28, 26, 24, 22, 20, 18, 16, 14, 12, 10, 8, 6, 4, 2, 0);
    const __m512i oddWords =
        _mm512_set_epi32(31, 29, 27, 25, 23, 21, 19, 17, 15, 13, 11, 9, 7, 5, 3, 1);
    for (int j = 0; j + 16 <= m; j += 16) {
        const __m512 nj = _mm512_loadu_ps(n + j);
        const __m512i w = _mm512_loadu_si512(words + j);
        // clamped = nj < 1 ? 1 : (nj > 32 ? 32 : nj)
        __m512 clamped = _mm512_mask_blend_ps(_mm512_cmp_ps_mask(nj, maxN, _CMP_GT_OQ), nj, maxN);
        clamped = _mm512_mask_blend_ps(_mm512_cmp_ps_mask(nj, one, _CMP_LT_OQ), clamped, one);
        const __m512i whole = _mm512_cvttps_epi32(clamped);
        const __mmask16 ok = _mm512_cmp_ps_mask(_mm512_cvtepi32_ps(whole), nj, _CMP_EQ_OQ);
        const __mmask16 none = _mm512_cmp_ps_mask(nj, _mm512_setzero_ps(), _CMP_EQ_OQ);
        const __m512 tf = _mm512_add_ps(_mm512_cvtepi32_ps(_mm512_and_si512(w, low31)), half);
        const __m512i bits = _mm512_castps_si512(tf);
        const __m512i octave =
            _mm512_sub_epi32(_mm512_and_si512(_mm512_srli_epi32(bits, 23), _mm512_set1_epi32(0xFF)),
                             _mm512_set1_epi32(126));
        const __m512i cell =
            _mm512_srli_epi32(_mm512_and_si512(bits, _mm512_set1_epi32(0x7FFFFF)), 17);
        const __m512 frac = _mm512_mul_ps(
            _mm512_cvtepi32_ps(_mm512_and_si512(bits, _mm512_set1_epi32(0x1FFFF))), fracScale);
        const __m512i halfIdx = _mm512_srli_epi32(w, 31);
        __m512i index = _mm512_mullo_epi32(halfIdx, _mm512_set1_epi32(GammaTable::kHalf));
        index = _mm512_add_epi32(index, _mm512_slli_epi32(octave, 6));  // × kCellsPerOctave
        index = _mm512_add_epi32(index, cell);
        index = _mm512_add_epi32(index,
                                 _mm512_mullo_epi32(_mm512_sub_epi32(whole, _mm512_set1_epi32(1)),
                                                    _mm512_set1_epi32(GammaTable::kPerShape)));
        // The two neighbouring points as one 64-bit read per lane (two 8-lane gathers, half
        // the element reads of two 16-lane ones), then split into q0 and q1.
        const __m512i pairsLo =
            _mm512_i32gather_epi64(_mm512_castsi512_si256(index), static_cast<const void*>(t), 4);
        const __m512i pairsHi = _mm512_i32gather_epi64(_mm512_extracti64x4_epi64(index, 1),
                                                       static_cast<const void*>(t), 4);
        const __m512 q0 =
            _mm512_castsi512_ps(_mm512_permutex2var_epi32(pairsLo, evenWords, pairsHi));
        const __m512 q1 =
            _mm512_castsi512_ps(_mm512_permutex2var_epi32(pairsLo, oddWords, pairsHi));
        const __m512 q = _mm512_add_ps(q0, _mm512_mul_ps(frac, _mm512_sub_ps(q1, q0)));
        // r = ok ? θ·q : (none ? 0 : −1)
        __m512 r = _mm512_mask_blend_ps(none, minusOne, _mm512_setzero_ps());
        r = _mm512_mask_blend_ps(ok, r, _mm512_mul_ps(th, q));
        _mm512_storeu_ps(out + j, r);
    }
}
static_assert(GammaTable::kCellsPerOctave == 64, "gammaDrawsAvx512 shifts by 6");
}  // namespace
#pragma GCC diagnostic pop
#endif

NVS_SIMD_CLONES void gammaTableDraws(const GammaTable& table, const float* __restrict n,
                                     const std::uint32_t* __restrict words, float* __restrict out,
                                     int m, float theta) noexcept {
    // Sixteen pixels at a time in GCC vector types (lowered to the clone's registers): the
    // table positions and fractions, then the sixteen pairs of table reads, then the draws.
    using V16f = float __attribute__((vector_size(64)));
    using V16i = std::int32_t __attribute__((vector_size(64)));
    const float* __restrict t = table.data();
    int j0 = 0;
#ifdef NVS_GAMMA_AVX512
    if (hostHasAvx512()) {
        gammaDrawsAvx512(t, n, words, out, m, theta);
        j0 = m / 16 * 16;
    }
#endif
    for (int j = j0; j < m; j += 16) {
        const int len = m - j < 16 ? m - j : 16;
        alignas(64) float nt[16] = {};
        alignas(64) std::uint32_t wt[16] = {};
        for (int l = 0; l < len; ++l) {
            nt[l] = n[j + l];
            wt[l] = words[j + l];
        }
        V16f nj;
        V16i w;
        std::memcpy(&nj, nt, sizeof nj);
        std::memcpy(&w, wt, sizeof w);
        // Whole N from 1 to kMaxN only (a noise-free photocathode passes fractional means).
        const V16f clamped = nj < 1.0f ? nj * 0.0f + 1.0f : (nj > 32.0f ? nj * 0.0f + 32.0f : nj);
        const V16i whole = __builtin_convertvector(clamped, V16i);
        const V16i ok = __builtin_convertvector(whole, V16f) == nj;
        const V16i none = nj == 0.0f;
        // locate(), lane by lane.
        const V16f tf = __builtin_convertvector(w & 0x7FFFFFFF, V16f) + 0.5f;
        V16i bits;  // tf's bits (memcpy, as rng.cpp's vectorBits)
        std::memcpy(&bits, &tf, sizeof bits);
        const V16i octave = ((bits >> 23) & 0xFF) - 126;
        const V16i cell = (bits & 0x7FFFFF) >> 17;
        const V16f frac = __builtin_convertvector(bits & 0x1FFFF, V16f) * 0x1.0p-17f;
        const V16i half = (w >> 31) & 1;  // arithmetic shift: −1 or 0, masked to 1 or 0
        const V16i index = half * GammaTable::kHalf + octave * GammaTable::kCellsPerOctave + cell +
                           (whole - 1) * GammaTable::kPerShape;
        alignas(64) float q0t[16], q1t[16];
        for (int l = 0; l < 16; ++l) {
            q0t[l] = t[index[l]];
            q1t[l] = t[index[l] + 1];
        }
        V16f q0, q1;
        std::memcpy(&q0, q0t, sizeof q0);
        std::memcpy(&q1, q1t, sizeof q1);
        const V16f q = q0 + frac * (q1 - q0);
        const V16f zero = nj * 0.0f;
        const V16f r = ok ? theta * q : (none ? zero : zero - 1.0f);
        alignas(64) float rt[16];
        std::memcpy(rt, &r, sizeof r);
        for (int l = 0; l < len; ++l)
            out[j + l] = rt[l];
    }
}

}  // namespace nvs
