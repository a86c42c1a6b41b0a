// PixelRng and PixelStream (sim/core/rng.h): the per-pixel noise words, Philox4x32-10 blocks made
// in lane loops and, on CPUs with AVX-512, in hand-written AVX-512 (the same words).
#include <algorithm>
#include <cstdint>
#include <cstring>

#include "sim/core/cpu_isa.h"
#include "sim/core/rng.h"
#include "sim/core/simd.h"

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(NVS_SINGLE_TARGET)
#include <immintrin.h>
#define NVS_PHILOX_AVX512 1
#endif

// No FMA contraction in any version of the loops (as in rng.cpp): the same bits on every CPU.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC optimize("fp-contract=off")
#endif

namespace nvs {

namespace {

// Philox4x32 constants (Salmon et al. 2011, Table 2; Random123 philox.h).
constexpr std::uint32_t kPhiloxM0 = 0xD2511F53u;
constexpr std::uint32_t kPhiloxM1 = 0xCD9E8D57u;
constexpr std::uint32_t kPhiloxW0 = 0x9E3779B9u;
constexpr std::uint32_t kPhiloxW1 = 0xBB67AE85u;
constexpr int kPhiloxRounds = 10;

// Lanes of blocks made together; loops over them vectorise (32×32→64 multiplies).
constexpr int kLanes = 8;

}  // namespace

// The bulk loops are compiled three times on x86-64: for the SSE2 baseline, for AVX2 and for
// AVX-512 (x86-64-v4: F, BW, CD, DQ, VL; Philox 1.6x faster than AVX2), chosen at load time by the
// CPU (GCC function multi-versioning). All give bit-identical results: the same integer and IEEE
// single-precision operations, and no FMA contraction in any version (see the pragma at the top of
// the file). Nothing is required of the build flags. The dispatch is NVS_SIMD_CLONES
// (sim/core/simd.h); the hand-written AVX-512 blocks run where hostHasAvx512() says so.

void philox4x32Block(const std::uint32_t key[2], const std::uint32_t ctr[4],
                     std::uint32_t out[4]) noexcept {
    std::uint32_t c0 = ctr[0], c1 = ctr[1], c2 = ctr[2], c3 = ctr[3];
    std::uint32_t k0 = key[0], k1 = key[1];
    for (int r = 0; r < kPhiloxRounds; ++r) {
        const std::uint64_t p0 = static_cast<std::uint64_t>(kPhiloxM0) * c0;
        const std::uint64_t p1 = static_cast<std::uint64_t>(kPhiloxM1) * c2;
        const std::uint32_t n0 = static_cast<std::uint32_t>(p1 >> 32) ^ c1 ^ k0;
        const std::uint32_t n2 = static_cast<std::uint32_t>(p0 >> 32) ^ c3 ^ k1;
        c1 = static_cast<std::uint32_t>(p1);
        c3 = static_cast<std::uint32_t>(p0);
        c0 = n0;
        c2 = n2;
        k0 += kPhiloxW0;
        k1 += kPhiloxW1;
    }
    out[0] = c0;
    out[1] = c1;
    out[2] = c2;
    out[3] = c3;
}

std::uint32_t PixelStream::next() noexcept {
    if (used_ == 4) {
        philox4x32Block(key_, ctr_, out_);
        // Block index in the low 8 bits of counter word 0 (the pixel's 1024-word sequence).
        ctr_[0] = (ctr_[0] & ~0xFFu) | ((ctr_[0] + 1u) & 0xFFu);
        used_ = 0;
    }
    return out_[used_++];
}

double PixelStream::uniform() noexcept {
    return uniformFromWord(next());
}

PixelRng::PixelRng(RngKey key, std::uint64_t frame) noexcept
    : key_{static_cast<std::uint32_t>(key.seed), static_cast<std::uint32_t>(key.seed >> 32)},
      c2_(static_cast<std::uint32_t>(frame)),
      c3_((key.stream << 16) | static_cast<std::uint32_t>((frame >> 32) & 0xFFFFu)) {}

void PixelRng::block(std::uint32_t y, std::uint32_t plane, std::uint32_t b,
                     std::uint32_t out[4]) const noexcept {
    const std::uint32_t ctr[4] = {(plane << 24) + b, y, c2_, c3_};
    philox4x32Block(key_, ctr, out);
}

PixelStream PixelRng::pixelStream(std::uint32_t x, std::uint32_t y) const noexcept {
    return PixelStream(key_[0], key_[1], 0x80000000u | ((x & 0x7FFFFFu) << 8), y, c2_, c3_);
}

#ifdef NVS_PHILOX_AVX512
// GCC 12's AVX-512 intrinsic headers trip -Wmaybe-uninitialized on their own "undefined"
// pass-through operands (a known false positive).
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
namespace {

// Philox4x32-10 blocks in AVX-512, written out because the compiler's version of the lane loops
// below keeps the round state in memory and widens and narrows the 32-bit lanes every round
// (about 3x slower). Each 64-bit lane holds one 32-bit counter word in its low half; a
// round's products are one vpmuludq each (it reads only the low halves), their high words
// one shift, the new words one three-way XOR; the high halves of the lanes carry bits that
// nothing reads. Eight blocks per vector, four vectors at a time (the rounds' multiplies
// overlap). Block i has counter word 0 = base + i, or base + list[i] when a list is given.
__attribute__((target("avx512f"))) void philoxAvx512(const std::uint32_t key[2], std::uint32_t base,
                                                     const std::uint32_t* list, std::uint32_t c1,
                                                     std::uint32_t c2, std::uint32_t c3, int n,
                                                     std::uint32_t* out) noexcept {
    constexpr int kG = 4;
    const __m512i m0 = _mm512_set1_epi64(kPhiloxM0);
    const __m512i m1 = _mm512_set1_epi64(kPhiloxM1);
    const __m512i w0 = _mm512_set1_epi64(kPhiloxW0);
    const __m512i w1 = _mm512_set1_epi64(kPhiloxW1);
    const __m512i iota = _mm512_set_epi64(7, 6, 5, 4, 3, 2, 1, 0);
    // Output order: blocks 0..3 from the low/high unpacks' 128-bit lanes 0 and 1, blocks
    // 4..7 from their lanes 2 and 3.
    const __m512i firstHalf = _mm512_set_epi64(11, 10, 3, 2, 9, 8, 1, 0);
    const __m512i secondHalf = _mm512_set_epi64(15, 14, 7, 6, 13, 12, 5, 4);
    const __m512i lo32 = _mm512_set1_epi64(0xFFFFFFFFll);
    for (int b = 0; b < n; b += 8 * kG) {
        __m512i x0[kG], x1[kG], x2[kG], x3[kG];
        for (int g = 0; g < kG; ++g) {
            const int first = b + 8 * g;
            if (list) {
                std::uint32_t ctr[8] = {};
                for (int i = 0; i < 8 && first + i < n; ++i)
                    ctr[i] = list[first + i];
                x0[g] = _mm512_add_epi64(_mm512_cvtepu32_epi64(_mm256_loadu_si256(
                                             reinterpret_cast<const __m256i*>(ctr))),
                                         _mm512_set1_epi64(base));
            } else {
                x0[g] = _mm512_add_epi64(iota, _mm512_set1_epi64(static_cast<long long>(
                                                   base + static_cast<std::uint32_t>(first))));
            }
            x1[g] = _mm512_set1_epi64(c1);
            x2[g] = _mm512_set1_epi64(c2);
            x3[g] = _mm512_set1_epi64(c3);
        }
        __m512i k0 = _mm512_set1_epi64(key[0]);
        __m512i k1 = _mm512_set1_epi64(key[1]);
        for (int r = 0; r < kPhiloxRounds; ++r) {
            for (int g = 0; g < kG; ++g) {
                const __m512i p0 = _mm512_mul_epu32(x0[g], m0);
                const __m512i p1 = _mm512_mul_epu32(x2[g], m1);
                x0[g] = _mm512_ternarylogic_epi64(_mm512_srli_epi64(p1, 32), x1[g], k0, 0x96);
                x2[g] = _mm512_ternarylogic_epi64(_mm512_srli_epi64(p0, 32), x3[g], k1, 0x96);
                x1[g] = p1;
                x3[g] = p0;
            }
            k0 = _mm512_add_epi64(k0, w0);
            k1 = _mm512_add_epi64(k1, w1);
        }
        for (int g = 0; g < kG; ++g) {
            const int first = b + 8 * g;
            if (first >= n) break;
            // (word 0, word 1) and (word 2, word 3) of each block in one 64-bit lane each.
            const __m512i a01 =
                _mm512_or_si512(_mm512_and_si512(x0[g], lo32), _mm512_slli_epi64(x1[g], 32));
            const __m512i a23 =
                _mm512_or_si512(_mm512_and_si512(x2[g], lo32), _mm512_slli_epi64(x3[g], 32));
            const __m512i lo = _mm512_unpacklo_epi64(a01, a23);  // blocks 0, 2, 4, 6
            const __m512i hi = _mm512_unpackhi_epi64(a01, a23);  // blocks 1, 3, 5, 7
            const __m512i v0 = _mm512_permutex2var_epi64(lo, firstHalf, hi);
            const __m512i v1 = _mm512_permutex2var_epi64(lo, secondHalf, hi);
            std::uint32_t* o = out + 4 * first;
            if (first + 8 <= n) {
                _mm512_storeu_si512(o, v0);
                _mm512_storeu_si512(o + 16, v1);
            } else {
                alignas(64) std::uint32_t tmp[32];
                _mm512_store_si512(tmp, v0);
                _mm512_store_si512(tmp + 16, v1);
                std::copy(tmp, tmp + 4 * (n - first), o);
            }
        }
    }
}

}  // namespace
#pragma GCC diagnostic pop
#endif

// kLanes blocks with counter words 0 = c0[i] and 1 … 3 = (cy, cf, cs), the first m written
// to out: plain loops over lane arrays, which vectorise in each clone of the callers. Each
// round's two 32×32→64 products are formed from 32-bit lanes widened to 64 bits (one pmuludq
// per vector), then split back into 32-bit lanes.
__attribute__((always_inline)) inline void philoxLanes(const std::uint32_t key[2],
                                                       const std::uint32_t* c0In, std::uint32_t cy,
                                                       std::uint32_t cf, std::uint32_t cs, int m,
                                                       std::uint32_t* __restrict out) noexcept {
    std::uint32_t c0[kLanes], c1[kLanes], c2[kLanes], c3[kLanes];
    for (int i = 0; i < kLanes; ++i) {
        c0[i] = c0In[i];
        c1[i] = cy;
        c2[i] = cf;
        c3[i] = cs;
    }
    std::uint32_t k0 = key[0], k1 = key[1];
    for (int r = 0; r < kPhiloxRounds; ++r) {
        std::uint64_t p0[kLanes], p1[kLanes];
        for (int i = 0; i < kLanes; ++i) {
            p0[i] = static_cast<std::uint64_t>(c0[i]) * kPhiloxM0;
            p1[i] = static_cast<std::uint64_t>(c2[i]) * kPhiloxM1;
        }
        for (int i = 0; i < kLanes; ++i) {
            c0[i] = static_cast<std::uint32_t>(p1[i] >> 32) ^ c1[i] ^ k0;
            c2[i] = static_cast<std::uint32_t>(p0[i] >> 32) ^ c3[i] ^ k1;
            c1[i] = static_cast<std::uint32_t>(p1[i]);
            c3[i] = static_cast<std::uint32_t>(p0[i]);
        }
        k0 += kPhiloxW0;
        k1 += kPhiloxW1;
    }
    for (int i = 0; i < m; ++i) {
        out[4 * i + 0] = c0[i];
        out[4 * i + 1] = c1[i];
        out[4 * i + 2] = c2[i];
        out[4 * i + 3] = c3[i];
    }
}

NVS_SIMD_CLONES void PixelRng::rowWords(std::uint32_t y, std::uint32_t plane, std::uint32_t b0,
                                        int nBlocks, std::uint32_t* __restrict out) const noexcept {
#ifdef NVS_PHILOX_AVX512
    if (hostHasAvx512()) {
        philoxAvx512(key_, (plane << 24) + b0, nullptr, y, c2_, c3_, nBlocks, out);
        return;
    }
#endif
    const std::uint32_t base = (plane << 24) + b0;
    for (int b = 0; b < nBlocks; b += kLanes) {
        std::uint32_t c0[kLanes];
        for (int i = 0; i < kLanes; ++i)
            c0[i] = base + static_cast<std::uint32_t>(b + i);
        philoxLanes(key_, c0, y, c2_, c3_, std::min(kLanes, nBlocks - b), out + 4 * b);
    }
}

// Blocks with counter word 0 = base + list[i] and words 1 … 3 = (c1, c2, c3), for listed
// row blocks (blocksAt) and the heads of pixel streams (streamHeads).
NVS_SIMD_CLONES void philoxListed(const std::uint32_t key[2], std::uint32_t base,
                                  const std::uint32_t* __restrict list, std::uint32_t cy,
                                  std::uint32_t cf, std::uint32_t cs, int n,
                                  std::uint32_t* __restrict out) noexcept {
#ifdef NVS_PHILOX_AVX512
    if (hostHasAvx512()) {
        philoxAvx512(key, base, list, cy, cf, cs, n, out);
        return;
    }
#endif
    for (int b = 0; b < n; b += kLanes) {
        const int m = std::min(kLanes, n - b);
        std::uint32_t c0[kLanes];
        for (int i = 0; i < kLanes; ++i)
            c0[i] = base + list[b + (i < m ? i : 0)];
        philoxLanes(key, c0, cy, cf, cs, m, out + 4 * b);
    }
}

void PixelRng::blocksAt(std::uint32_t y, std::uint32_t plane, const std::uint32_t* blocks, int n,
                        std::uint32_t* out) const noexcept {
    philoxListed(key_, plane << 24, blocks, y, c2_, c3_, n, out);
}

void PixelRng::streamHeads(std::uint32_t y, const std::uint32_t* xs, int n,
                           std::uint32_t* out) const noexcept {
    // pixelStream(x, y)'s counter word 0 is 0x80000000 | (x & 0x7FFFFF) << 8 for its block 0.
    constexpr int kPart = 256;
    std::uint32_t list[kPart];
    for (int b = 0; b < n; b += kPart) {
        const int m = std::min(kPart, n - b);
        for (int i = 0; i < m; ++i)
            list[i] = (xs[b + i] & 0x7FFFFFu) << 8;
        philoxListed(key_, 0x80000000u, list, y, c2_, c3_, m, out + 4 * b);
    }
}

PixelStream::PixelStream(const PixelStream& fresh, const std::uint32_t head[4], int used) noexcept
    : PixelStream(fresh) {
    for (int i = 0; i < 4; ++i)
        out_[i] = head[i];
    used_ = used;
    ctr_[0] = (ctr_[0] & ~0xFFu) | ((ctr_[0] + 1u) & 0xFFu);  // as next() after block 0
}

}  // namespace nvs
