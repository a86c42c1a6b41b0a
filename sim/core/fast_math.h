#pragma once
// Elementary functions written so that a loop over them vectorises (no libm call, no branch),
// to single precision. libm's scalar calls stop GCC's vectoriser, and glibc's vector variants
// (libmvec) are declared only under -ffast-math, which the camera chain does not use (its sums
// must be the same bits on every machine, sim/sensor/CMakeLists.txt).

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstdint>

namespace nvs {

// 1 − e^(−u) for u ≥ 0 in single precision, branch-free so that a row of it vectorises (libm's
// expm1f is a scalar call, and glibc's vector variants are reachable only under -ffast-math):
// below u = 1/2 the Taylor series to u⁸ (truncation < 3e-7 relative), above it 1 − 2^(−n)·e^(−f)
// with n = round(u·log₂e), f = u − n·ln 2 with ln 2 in two parts (Cody & Waite; the split of
// Cephes' expf) and e^(−f), |f| ≤ ln2/2, by its Taylor series to f⁷ (< 2e-8); u is held at 87
// (e^(−87) is below float's epsilon against 1). Within 1e-7 relative of expm1 (test).
// oneMinusExpNeg's value for u < 1/2 (its Taylor branch alone: the same bits there), for a
// loop that knows all its u are below 1/2 and need not form the other branch.
__attribute__((always_inline)) inline float oneMinusExpNegSmall(float u) {
    return u * (1.0f -
                u * (0.5f -
                     u * (1.0f / 6.0f -
                          u * (1.0f / 24.0f -
                               u * (1.0f / 120.0f -
                                    u * (1.0f / 720.0f - u * (1.0f / 5040.0f - u / 40320.0f)))))));
}

__attribute__((always_inline)) inline float oneMinusExpNeg(float u) {
    const float t = oneMinusExpNegSmall(u);
    const float v = std::min(u, 87.0f);
    const float nf = std::nearbyint(v * 1.44269504f);
    const float f = (v - nf * 0.693359375f) + nf * 2.12194440e-4f;  // ln 2 = hi − lo
    const float p =
        1.0f -
        f * (1.0f - f * (0.5f - f * (1.0f / 6.0f - f * (1.0f / 24.0f -
                                                        f * (1.0f / 120.0f -
                                                             f * (1.0f / 720.0f - f / 5040.0f))))));
    // 2^(−n) by its exponent bits (n ≤ 126: a normal float).
    const float scale = std::bit_cast<float>((127 - static_cast<std::int32_t>(nf)) << 23);
    return u < 0.5f ? t : 1.0f - scale * p;
}

}  // namespace nvs
