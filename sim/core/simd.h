#pragma once
// The one SIMD dispatch of nvstim's own per-pixel loops (docs/portability.md).
//
// NVS_SIMD_CLONES before a function compiles it three times on x86-64 with GCC: for the SSE2
// baseline, for AVX2 and for AVX-512 (x86-64-v4: F, BW, CD, DQ, VL), the version picked at load
// time by the CPU (GCC function multi-versioning). Every version does the same IEEE operations
// in the same order — the libraries that use it are built with -ffp-contract=off (no FMA
// contraction in any version) — so every CPU gives the same bits. Elsewhere (another compiler
// or architecture, or NVS_SINGLE_TARGET: the build for one target, tests/isa) it is empty.
//
// Hand-written AVX-512 kernels beside it ask the one CPU probe, hostHasAvx512()
// (sim/core/cpu_isa.h), whether they may run.

#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(NVS_SINGLE_TARGET)
#define NVS_SIMD_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define NVS_SIMD_CLONES
#endif
