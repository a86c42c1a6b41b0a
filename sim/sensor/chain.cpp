#include "sim/sensor/chain.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define NVS_PHOSPHOR_AVX512 1
#endif

#include <fftw3.h>

#include <algorithm>
#include <bit>
#include <cmath>
#include <filesystem>

#include "sim/core/fast_math.h"
#include "sim/core/input_file.h"
#include "sim/core/rng.h"
#include "sim/core/units.h"
#include "sim/sensor/half.h"
#include "sim/sensor/mtf.h"

namespace nvs::sensor {

namespace {

// Photometric → photoelectron rate: lm/m² × A/lm ÷ e.
double ebiRatePerPixel_pe_s(const CameraParams& c) {
    const double ebi_lm_m2 = c.ebi_lm_cm2 * 1e4;
    const double current_A_m2 = ebi_lm_m2 * c.cathode_sensitivity_uA_lm * 1e-6;
    return current_A_m2 / kElectronCharge_C * c.pixelAreaAtCathode_m2();
}

// Row scratch length: the width rounded up to whole vector chunks and Philox blocks.
inline std::size_t paddedRow(int width) {
    return static_cast<std::size_t>((width + kRowPad_px - 1) / kRowPad_px * kRowPad_px);
}
// Rows (or columns) [begin, end) of band b of n: the same bands whatever runs them.
inline int bandStart(int b, int n) {
    return static_cast<int>(static_cast<long long>(b) * n / kChainSlots);
}
// Philox blocks that cover `n` words.
inline int blocksFor(int n) {
    return (n + 3) / 4;
}

}  // namespace

// The per-pixel row loops below are compiled for the x86-64 baseline, AVX2 and AVX-512
// (x86-64-v4) and picked at load time (GCC function multi-versioning). The library is built
// with -ffp-contract=off, so every version does the same IEEE operations: the same bits on
// any CPU.
#if defined(__x86_64__) && defined(__GNUC__) && !defined(__clang__) && !defined(NVS_SINGLE_TARGET)
#define NVS_ROW_CLONES __attribute__((target_clones("arch=x86-64-v4", "avx2", "default")))
#else
#define NVS_ROW_CLONES
#endif

namespace {

// Optics row: rate = Lpe·k with bad pixels as 0, k = onAxis/(1 + (r/f)²)² (cos⁴θ, r² from
// the column's and the row's parts); returns the bad count. The row sum is kept in 16 lanes
// (so that the loop vectorises) and added up in double.
NVS_ROW_CLONES int opticsRowKernel(const float* __restrict in, const float* __restrict dx2,
                                   float dy2, float onAxis, float* __restrict out, int w,
                                   double* rowSum) noexcept {
    constexpr int kL = 16;
    float acc[kL] = {};
    int bad = 0;
    int x = 0;
    for (; x + kL <= w; x += kL) {
        for (int j = 0; j < kL; ++j) {
            const float v = in[x + j];
            // NaN fails both comparisons; +inf fails the second.
            const bool ok = (v >= 0.0f) & (v < 3.0e38f);
            bad += static_cast<int>(!ok);
            const float t = 1.0f + (dx2[x + j] + dy2);
            const float r = (ok ? v : 0.0f) * (onAxis / (t * t));
            out[x + j] = r;
            acc[j] += r;
        }
    }
    for (; x < w; ++x) {
        const float v = in[x];
        const bool ok = (v >= 0.0f) & (v < 3.0e38f);
        bad += static_cast<int>(!ok);
        const float t = 1.0f + (dx2[x] + dy2);
        const float r = (ok ? v : 0.0f) * (onAxis / (t * t));
        out[x] = r;
        acc[x % kL] += r;
    }
    double sum = 0.0;
    for (int j = 0; j < kL; ++j)
        sum += static_cast<double>(acc[j]);
    *rowSum = sum;
    return bad;
}

// Photocathode means: (rate + ebi)·t.
NVS_ROW_CLONES void cathodeMeanKernel(const float* __restrict r, float* __restrict mean, int w,
                                      float ebi, float t) noexcept {
    for (int x = 0; x < w; ++x)
        mean[x] = (r[x] + ebi) * t;
}

// Σ v in 16 float lanes, added up in double (as the other row sums).
NVS_ROW_CLONES double rowSumOf(const float* __restrict v, int w) noexcept {
    constexpr int kL = 16;
    float acc[kL] = {};
    int x = 0;
    for (; x + kL <= w; x += kL) {
        for (int j = 0; j < kL; ++j)
            acc[j] += v[x + j];
    }
    for (; x < w; ++x)
        acc[x % kL] += v[x];
    double sum = 0.0;
    for (int j = 0; j < kL; ++j)
        sum += static_cast<double>(acc[j]);
    return sum;
}

// Noise-free MCP: v·G in place; returns the row sum.
NVS_ROW_CLONES double mcpMeanKernel(float* __restrict v, int w, float g) noexcept {
    for (int x = 0; x < w; ++x)
        v[x] *= g;
    return rowSumOf(v, w);
}

// Marsaglia–Tsang's first attempt for m pixels with n photoelectrons: e = θ·d·(1 + c·z)³ when
// the squeeze accepts, else 0 (the caller finishes those, and shapes below 1, with
// gammaFromNormal).
NVS_ROW_CLONES void gammaFirstAttemptKernel(const float* __restrict n, const float* __restrict z,
                                            const std::uint32_t* __restrict uw,
                                            double* __restrict e, int m, double k,
                                            double theta) noexcept {
    for (int j = 0; j < m; ++j) {
        const double shape = static_cast<double>(n[j]) * k;
        const double d = shape - 1.0 / 3.0;
        const double c = 1.0 / std::sqrt(9.0 * (shape >= 1.0 ? d : 1.0));
        const double zz = static_cast<double>(z[j]);
        const double u = uniformFromWord(uw[j]);
        double t = 1.0 + c * zz;
        t = t * t * t;
        const bool ok = (shape >= 1.0) & (t > 0.0) & (u < 1.0 - 0.0331 * (zz * zz) * (zz * zz));
        e[j] = ok ? theta * d * t : 0.0;
    }
}

// Phosphor row with M stored components (a fixed shape, so that the loop vectorises). The
// state of a row is interleaved in blocks of kPhosphorBlock pixels: the block's values of
// component 0, then of component 1, … (PhosphorStage::state_), one memory stream instead of
// M (half the time of separate planes: the hardware prefetcher keeps up with one stream).
constexpr int kPhosphorBlock = 16;

// A stored afterglow below kPhosphorFloor_e CCD electrons is stored as zero. Without the
// floor an unlit pixel's store decays geometrically through the subnormal floats (below
// 1.2e-38), where each x86 multiply takes a microcode assist (~100x slower): in a dim scene,
// where most pixels are unlit in any field, that was most of the phosphor's time. With the
// floor every stored value is 0 or ≥ 1e-10, and its product with a decay factor ≥ 1e-20
// (PhosphorStage treats smaller ones as 0) is a normal float.
constexpr float kPhosphorFloor_e = 1e-10f;

template <int M>
inline __attribute__((always_inline)) void phosphorBlock(const float* __restrict in,
                                                         float* __restrict out, float* __restrict s,
                                                         int n, float nowEta, const float* k,
                                                         const float* dc,
                                                         const float* em) noexcept {
    constexpr int B = kPhosphorBlock;
    for (int x = 0; x < n; ++x) {
        const float e = in[x];
        float o = e * nowEta;
        for (int j = 0; j < M; ++j) {
            const float a = s[j * B + x];
            o += a * em[j];
            const float next = a * dc[j] + e * k[j];
            s[j * B + x] = next < kPhosphorFloor_e ? 0.0f : next;
        }
        out[x] = o;
    }
}

template <int M>
inline __attribute__((always_inline)) void phosphorRowBody(
    const float* __restrict in, float* __restrict out, float* __restrict st, int w, float nowEta,
    const float* k, const float* dc, const float* em) noexcept {
    constexpr int B = kPhosphorBlock;
    float kk[M > 0 ? M : 1], dd[M > 0 ? M : 1], ee[M > 0 ? M : 1];
    for (int j = 0; j < M; ++j) {
        kk[j] = k[j];
        dd[j] = dc[j];
        ee[j] = em[j];
    }
    int b = 0;
    for (; b + B <= w; b += B)
        phosphorBlock<M>(in + b, out + b, st + static_cast<std::ptrdiff_t>(b) * M, B, nowEta, kk,
                         dd, ee);
    if (b < w)
        phosphorBlock<M>(in + b, out + b, st + static_cast<std::ptrdiff_t>(b) * M, w - b, nowEta,
                         kk, dd, ee);
}

#define NVS_PHOSPHOR_ROW(M)                                                           \
    NVS_ROW_CLONES void phosphorRow##M(const float* in, float* out, float* st, int w, \
                                       float nowEta, const float* k, const float* dc, \
                                       const float* em) noexcept {                    \
        phosphorRowBody<M>(in, out, st, w, nowEta, k, dc, em);                        \
    }
NVS_PHOSPHOR_ROW(0)
NVS_PHOSPHOR_ROW(1)
NVS_PHOSPHOR_ROW(2)
NVS_PHOSPHOR_ROW(3)
NVS_PHOSPHOR_ROW(4)
#undef NVS_PHOSPHOR_ROW

// CCD load: max(src, 0)·(1 + PRNU) + dark and the column maxima; WithSums: also the
// column sums (smear). One body, two vector-cloned kernels (as the phosphor rows above).
template <bool WithSums>
inline __attribute__((always_inline)) void ccdLoadBody(
    const float* __restrict src, const float* __restrict prnu, float* __restrict dst,
    float* __restrict cmax, float* __restrict csum, int w, float dark) noexcept {
    if (prnu) {
        for (int x = 0; x < w; ++x) {
            const float s = src[x];
            const float v = (s < 0.0f ? 0.0f : s) * prnu[x] + dark;
            dst[x] = v;
            cmax[x] = cmax[x] < v ? v : cmax[x];
            if constexpr (WithSums) csum[x] += v;
        }
    } else {
        for (int x = 0; x < w; ++x) {
            const float s = src[x];
            const float v = (s < 0.0f ? 0.0f : s) + dark;
            dst[x] = v;
            cmax[x] = cmax[x] < v ? v : cmax[x];
            if constexpr (WithSums) csum[x] += v;
        }
    }
}
NVS_ROW_CLONES void ccdLoadKernel(const float* __restrict src, const float* __restrict prnu,
                                  float* __restrict dst, float* __restrict cmax,
                                  float* __restrict csum, int w, float dark) noexcept {
    ccdLoadBody<true>(src, prnu, dst, cmax, csum, w, dark);
}
NVS_ROW_CLONES void ccdLoadMaxKernel(const float* __restrict src, const float* __restrict prnu,
                                     float* __restrict dst, float* __restrict cmax, int w,
                                     float dark) noexcept {
    ccdLoadBody<false>(src, prnu, dst, cmax, nullptr, w, dark);
}

// Column sums of a row: cs += v.
NVS_ROW_CLONES void addRowKernel(const float* __restrict v, float* __restrict cs, int w) noexcept {
    for (int x = 0; x < w; ++x)
        cs[x] += v[x];
}

// Read-out row: v += smear + σ·z.
NVS_ROW_CLONES void ccdReadKernel(float* __restrict v, const float* __restrict cs,
                                  const float* __restrict z, int w, float sigma) noexcept {
    for (int x = 0; x < w; ++x)
        v[x] += cs[x] + sigma * z[x];
}

// Video, linear: round to nearest even by the 1.5·2²³ trick (exact for |x| < 2²²; the value
// is clamped to [−1, max + 1] first), then clamp to the ADC range. Returns the row's sum.
NVS_ROW_CLONES std::int64_t videoLinearKernel(const float* __restrict s, float* __restrict o,
                                              std::uint16_t* __restrict v, int w, float gain,
                                              float offset, float maxc) noexcept {
    std::int32_t sum = 0;
    for (int x = 0; x < w; ++x) {
        float dc = s[x] * gain + offset;
        dc = dc < -1.0f ? -1.0f : dc;
        dc = dc > maxc + 1.0f ? maxc + 1.0f : dc;
        dc = (dc + 0x1.8p23f) - 0x1.8p23f;
        dc = dc < 0.0f ? 0.0f : dc;
        dc = dc > maxc ? maxc : dc;
        o[x] = dc;
        const std::int32_t n = static_cast<std::int32_t>(dc);
        v[x] = static_cast<std::uint16_t>(n);
        sum += n;
    }
    return sum;
}

// Video, gamma with a one-step threshold table (VideoStage): signals above zero take the
// table's level, the others the linear conversion.
NVS_ROW_CLONES std::int64_t videoGammaKernel(const float* __restrict s, float* __restrict o,
                                             std::uint16_t* __restrict v, int w, float gain,
                                             float offset, float maxc,
                                             const std::int32_t* __restrict lut,
                                             const float* __restrict thr, float lutScale, float top,
                                             float bottom) noexcept {
    std::int32_t sum = 0;
    for (int x = 0; x < w; ++x) {
        float dc = s[x] * gain + offset;
        dc = dc < -1.0f ? -1.0f : dc;
        dc = dc > maxc + 1.0f ? maxc + 1.0f : dc;
        dc = (dc + 0x1.8p23f) - 0x1.8p23f;
        dc = dc < 0.0f ? 0.0f : dc;
        dc = dc > maxc ? maxc : dc;
        const float sig = s[x] * gain;
        float cellf = sig * lutScale;
        cellf = cellf > 0.0f ? cellf : 0.0f;
        cellf = cellf < top ? cellf : top;
        const std::int32_t j0 = lut[static_cast<std::int32_t>(cellf)];
        const std::int32_t j = j0 + static_cast<std::int32_t>(thr[j0] <= sig);
        float level = bottom + static_cast<float>(j);
        level = level < maxc ? level : maxc;
        const float out = sig > 0.0f ? level : dc;
        o[x] = out;
        const std::int32_t n = static_cast<std::int32_t>(out);
        v[x] = static_cast<std::uint16_t>(n);
        sum += n;
    }
    return sum;
}

// MCP row scans (McpStage::applyRow): how many pixels draw (v > 0), and whether any draw of
// a chunk of 16 is past the table (e < 0).
NVS_ROW_CLONES int countPositive(const float* __restrict v, int w) noexcept {
    int m = 0;
    for (int x = 0; x < w; ++x)
        m += v[x] > 0.0f ? 1 : 0;
    return m;
}
NVS_ROW_CLONES int countNegative(const float* __restrict e, int n) noexcept {
    int any = 0;
    for (int l = 0; l < n; ++l)
        any += e[l] < 0.0f ? 1 : 0;
    return any;
}

// Halo (HaloStage), in vector clones like the other row loops; each output element is
// computed by itself, in the same order in every clone.
// Cell sums of one pixel row: c[cx] += Σ_k r[cx·kBlock + k] over the whole cells.
template <int B>
inline __attribute__((always_inline)) void haloCellSumsBody(const float* __restrict r,
                                                            float* __restrict c,
                                                            int cells) noexcept {
    for (int cx = 0; cx < cells; ++cx) {
        float acc = 0.0f;
        for (int k = 0; k < B; ++k)
            acc += r[cx * B + k];
        c[cx] += acc;
    }
}
NVS_ROW_CLONES void haloCellSums4(const float* r, float* c, int cells) noexcept {
    haloCellSumsBody<4>(r, c, cells);
}
// out[i] += k·src[i]: one tap of the halo's disk over a row of cells.
NVS_ROW_CLONES void haloTapKernel(float* __restrict out, const float* __restrict src, float k,
                                  int n) noexcept {
    for (int i = 0; i < n; ++i)
        out[i] += k * src[i];
}
// A pixel row back from its cells: r = keep·r + share·spread of its cell.
// In place (out = r) or into another row (the image row read, not written back).
template <int B>
inline __attribute__((always_inline)) void haloAddBackBody(const float* r, float* out,
                                                           const float* __restrict sp, int cells,
                                                           float keep, float share) noexcept {
    for (int cx = 0; cx < cells; ++cx) {
        const float add = share * sp[cx];
        for (int k = 0; k < B; ++k)
            out[cx * B + k] = keep * r[cx * B + k] + add;
    }
}
NVS_ROW_CLONES void haloAddBack4(float* r, const float* sp, int cells, float keep,
                                 float share) noexcept {
    haloAddBackBody<4>(r, r, sp, cells, keep, share);
}
NVS_ROW_CLONES void haloAddBack4To(const float* __restrict r, float* __restrict out,
                                   const float* sp, int cells, float keep, float share) noexcept {
    haloAddBackBody<4>(r, out, sp, cells, keep, share);
}

}  // namespace

namespace detail {

// ---- The phosphor's state in binary16 (PhosphorStage::boundInput) ----
// One block of the half-precision state: as phosphorBlock (the same operations in the same
// order), the stores as binary16 of store·inv[j] (inv = 1/scale, powers of two: exact).
static void phosphorBlockHalf(const float* __restrict in, float* __restrict out,
                              std::uint16_t* __restrict s, int n, int m, float nowEta,
                              const float* k, const float* dc, const float* em, const float* scale,
                              const float* inv) noexcept {
    constexpr int B = kPhosphorBlock;
    for (int x = 0; x < n; ++x) {
        const float e = in[x];
        float o = e * nowEta;
        for (int j = 0; j < m; ++j) {
            const float a = floatFromHalf(s[j * B + x]) * scale[j];
            o += a * em[j];
            const float next = a * dc[j] + e * k[j];
            s[j * B + x] = halfFromFloat((next < kPhosphorFloor_e ? 0.0f : next) * inv[j]);
        }
        out[x] = o;
    }
}

void phosphorRowHalf(const float* in, float* out, std::uint16_t* st, int w, int m, float nowEta,
                     const float* k, const float* dc, const float* em, const float* scale,
                     const float* inv) noexcept {
    constexpr int B = kPhosphorBlock;
    for (int b = 0; b < w; b += B)
        phosphorBlockHalf(in + b, out + b, st + static_cast<std::ptrdiff_t>(b) * m,
                          std::min(B, w - b), m, nowEta, k, dc, em, scale, inv);
}

#ifdef NVS_PHOSPHOR_AVX512
// GCC 12's AVX-512 headers trip -Wmaybe-uninitialized on their own pass-through operands.
#pragma GCC diagnostic push
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
// The same with 16 pixels a vector and the hardware's conversions (vcvtph2ps / vcvtps2ph,
// round to nearest even): the same bits as phosphorRowHalf. Whole blocks here, the last
// partial one by phosphorBlockHalf.
__attribute__((target("avx512f"))) void phosphorRowHalfAvx512(
    const float* in, float* out, std::uint16_t* st, int w, int m, float nowEta, const float* k,
    const float* dc, const float* em, const float* scale, const float* inv) noexcept {
    constexpr int B = kPhosphorBlock;
    static_assert(B == 16, "one vector a block");
    const __m512 vNow = _mm512_set1_ps(nowEta);
    const __m512 vFloor = _mm512_set1_ps(kPhosphorFloor_e);
    int b = 0;
    for (; b + B <= w; b += B) {
        const __m512 e = _mm512_loadu_ps(in + b);
        __m512 o = _mm512_mul_ps(e, vNow);
        std::uint16_t* s = st + static_cast<std::ptrdiff_t>(b) * m;
        for (int j = 0; j < m; ++j) {
            __m256i* sj = reinterpret_cast<__m256i*>(s + j * B);
            const __m512 a =
                _mm512_mul_ps(_mm512_cvtph_ps(_mm256_loadu_si256(sj)), _mm512_set1_ps(scale[j]));
            o = _mm512_add_ps(o, _mm512_mul_ps(a, _mm512_set1_ps(em[j])));
            __m512 next = _mm512_add_ps(_mm512_mul_ps(a, _mm512_set1_ps(dc[j])),
                                        _mm512_mul_ps(e, _mm512_set1_ps(k[j])));
            next = _mm512_maskz_mov_ps(_mm512_cmp_ps_mask(next, vFloor, _CMP_NLT_UQ), next);
            next = _mm512_mul_ps(next, _mm512_set1_ps(inv[j]));
            _mm256_storeu_si256(
                sj, _mm512_cvtps_ph(next, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
        }
        _mm512_storeu_ps(out + b, o);
    }
    if (b < w)
        phosphorBlockHalf(in + b, out + b, st + static_cast<std::ptrdiff_t>(b) * m, w - b, m,
                          nowEta, k, dc, em, scale, inv);
}
#pragma GCC diagnostic pop

bool phosphorHasAvx512() noexcept {
    static const bool has = [] {
        __builtin_cpu_init();
        return __builtin_cpu_supports("avx512f") != 0;
    }();
    return has;
}
#else
void phosphorRowHalfAvx512(const float* in, float* out, std::uint16_t* st, int w, int m,
                           float nowEta, const float* k, const float* dc, const float* em,
                           const float* scale, const float* inv) noexcept {
    phosphorRowHalf(in, out, st, w, m, nowEta, k, dc, em, scale, inv);
}
bool phosphorHasAvx512() noexcept {
    return false;
}
#endif

}  // namespace detail

// ---- 1. Optics ------------------------------------------------------------------------------

OpticsStage::OpticsStage(const CameraParams& c)
    : onAxis_(static_cast<float>(c.peRatePerLpe_on_axis())),
      dx2_(static_cast<std::size_t>(c.width), 0.0f),
      dy2_(static_cast<std::size_t>(c.height), 0.0f) {
    // cos⁴θ off axis: cos θ = f / sqrt(f² + r²), r the distance on the cathode, so
    // cos⁴θ = 1/(1 + (r/f)²)² with (r/f)² = (dx/f)² + (dy/f)², a column part and a row part.
    if (!c.cos4) return;
    const double px_m = c.pitch_x_um * 1e-6 * c.taper_magnification;
    const double py_m = c.pitch_y_um * 1e-6 * c.taper_magnification;
    const double f_m = c.focal_length_mm * 1e-3;
    const double cx = 0.5 * (c.width - 1);
    const double cy = 0.5 * (c.height - 1);
    for (int x = 0; x < c.width; ++x) {
        const double a = (x - cx) * px_m / f_m;
        dx2_[static_cast<std::size_t>(x)] = static_cast<float>(a * a);
    }
    for (int y = 0; y < c.height; ++y) {
        const double a = (y - cy) * py_m / f_m;
        dy2_[static_cast<std::size_t>(y)] = static_cast<float>(a * a);
    }
}

std::int64_t OpticsStage::apply(ImageView<const float> lpe, ImageView<float> rate,
                                FieldContext& ctx) const noexcept {
    std::int64_t bad = 0;
    double total = 0.0;
    for (int y = 0; y < lpe.height(); ++y) {
        double rowSum = 0.0;
        bad += applyRow(lpe.row(y), rate.row(y), y, rowSum);
        total += rowSum;
    }
    ctx.cathodeRate_pe_s += total;
    return bad;
}

int OpticsStage::applyRow(const float* lpe, float* rate, int y, double& rowSum) const noexcept {
    return opticsRowKernel(lpe, dx2_.data(), dy2_[static_cast<std::size_t>(y)], onAxis_, rate,
                           static_cast<int>(dx2_.size()), &rowSum);
}

// ---- 2. Gate --------------------------------------------------------------------------------

GateStage::GateStage(const CameraParams& c) : gate_s_(c.gate_s), min_s_(c.gate_min_s) {}

double GateStage::gate_s(double period_s, double autogateScale) const noexcept {
    const double base = (gate_s_ > 0.0 && gate_s_ < period_s) ? gate_s_ : period_s;
    return std::clamp(base * autogateScale, std::min(min_s_, base), base);
}

// ---- 3. Photocathode ------------------------------------------------------------------------

PhotocathodeStage::PhotocathodeStage(const CameraParams& c, std::uint64_t seed)
    : noise_(c.shot_noise),
      ebi_pe_s_(ebiRatePerPixel_pe_s(c)),
      seed_(seed),
      stride_(paddedRow(c.width)),
      mean_(new float[kChainSlots * stride_]),
      words_(new std::uint32_t[kChainSlots * stride_]) {}

void PhotocathodeStage::apply(ImageView<const float> rate, ImageView<float> pe,
                              FieldContext& ctx) noexcept {
    begin(ctx, rate.width(), rate.height());
    for (int y = 0; y < rate.height(); ++y)
        applyRow(rate.row(y), pe.row(y), rate.width(), y);
}

void PhotocathodeStage::begin(FieldContext& ctx, int w, int h) noexcept {
    t_s_ = static_cast<float>(ctx.gate_s);
    field_ = ctx.field;
    ctx.cathodeRate_pe_s += ebi_pe_s_ * w * h;
}

void PhotocathodeStage::applyRow(const float* rate, float* pe, int w, int y, int slot) noexcept {
    const float ebi = static_cast<float>(ebi_pe_s_);
    if (!noise_) {
        cathodeMeanKernel(rate, pe, w, ebi, t_s_);
        return;
    }
    // One word per pixel; Poisson by the exact row sampler (zeros settled in a vector pass,
    // the rest by inversion or PTRS).
    const std::size_t off = static_cast<std::size_t>(slot) * stride_;
    float* __restrict mean = mean_.get() + off;
    std::uint32_t* __restrict words = words_.get() + off;
    cathodeMeanKernel(rate, mean, w, ebi, t_s_);
    const PixelRng rng(seed_, RngStream::Photocathode, field_);
    const std::uint32_t yy = static_cast<std::uint32_t>(y);
    rng.rowWords(yy, 0, 0, blocksFor(w), words);
    poissonRow(mean, words, pe, w, rng, 0, yy);
}

// ---- 4. BSP ---------------------------------------------------------------------------------

// ---- 3b. Halo ------------------------------------------------------------------------------

HaloStage::HaloStage(const CameraParams& c)
    : enabled_(c.halo_enabled && c.halo_fraction > 0.0), w_(c.width), h_(c.height) {
    if (!enabled_) return;
    fraction_ = static_cast<float>(c.halo_fraction);
    cw_ = (w_ + kBlock - 1) / kBlock;
    ch_ = (h_ + kBlock - 1) / kBlock;
    // Cell size at the cathode [µm] (the CCD pitch seen through the taper).
    const double cx_um = kBlock * c.pitch_x_um * c.taper_magnification;
    const double cy_um = kBlock * c.pitch_y_um * c.taper_magnification;
    const double r_um = c.haloRadius_um();
    kr_ = static_cast<int>(std::ceil(r_um / std::min(cx_um, cy_um)));
    const int n = 2 * kr_ + 1;
    kernel_.assign(static_cast<std::size_t>(n) * n, 0.0f);
    // Each cell's weight: the ring density integrated over the cell, 8×8 samples a cell; the
    // density's integrable rim singularity is held at r/R ≤ 0.999.
    constexpr int kSub = 8;
    double total = 0.0;
    std::vector<double> wsum(kernel_.size(), 0.0);
    for (int j = -kr_; j <= kr_; ++j)
        for (int i = -kr_; i <= kr_; ++i) {
            double acc = 0.0;
            for (int b = 0; b < kSub; ++b)
                for (int a = 0; a < kSub; ++a) {
                    const double x = (i + (a + 0.5) / kSub - 0.5) * cx_um;
                    const double y = (j + (b + 0.5) / kSub - 0.5) * cy_um;
                    const double u = std::hypot(x, y) / r_um;
                    if (u >= 1.0) continue;
                    // p(r) dr ∝ dr/√(1 − u²); per area: divide by 2πr.
                    acc += 1.0 / (std::sqrt(1.0 - std::min(u, 0.999) * std::min(u, 0.999)) *
                                  std::max(u, 0.5 / kSub));
                }
            wsum[static_cast<std::size_t>((j + kr_) * n + (i + kr_))] = acc;
            total += acc;
        }
    for (std::size_t k = 0; k < kernel_.size(); ++k)
        kernel_[k] = static_cast<float>(wsum[k] / total);
    cells_ = ImageF(cw_, ch_);
    spread_ = ImageF(cw_, ch_);
}

void HaloStage::apply(ImageView<float> rate) noexcept {
    SerialExecutor serial;
    apply(rate, serial);
}

void HaloStage::apply(ImageView<float> rate, RowExecutor& exec) noexcept {
    if (!enabled_) return;
    const ImageView<const float> in(rate.row(0), rate.width(), rate.height(), rate.stride_px());
    auto cells = [&](int b) { sumCells(in, bandStart(b, ch_), bandStart(b + 1, ch_)); };
    forEachIndex(exec, kChainSlots, cells);
    spread(exec);
    auto back = [&](int b) {
        for (int y = bandStart(b, h_); y < bandStart(b + 1, h_); ++y)
            addBackRow(rate.row(y), y);
    };
    forEachIndex(exec, kChainSlots, back);
}

// The loops run along rows with the column index innermost and no division, so that they
// vectorise (this stage is on every field's path).
static_assert(HaloStage::kBlock == 4, "haloCellSums4 and haloAddBack4 are for cells of 4 pixels");

void HaloStage::sumCells(ImageView<const float> rate, int cy0, int cy1) noexcept {
    // 1. Sum the rate over each cell: a cell row from its kBlock pixel rows, top to bottom.
    const int fullCells = w_ / kBlock;  // cells of kBlock whole pixels; the last may be partial
    for (int cy = cy0; cy < cy1; ++cy) {
        float* c = cells_.row(cy);
        std::fill(c, c + cw_, 0.0f);
        for (int y = cy * kBlock; y < std::min(h_, (cy + 1) * kBlock); ++y) {
            const float* r = rate.row(y);
            haloCellSums4(r, c, fullCells);
            for (int x = fullCells * kBlock; x < w_; ++x)
                c[fullCells] += r[x];
        }
    }
}

void HaloStage::spread(RowExecutor& exec) noexcept {
    // 2. Spread each cell over the disk (cells off the image are lost: the halo's share of
    // light near the border leaves the frame, as on the tube): out(cx, cy) = Σ_ij
    // K(i, j)·cells(cx − i, cy − j), one kernel tap at a time over a whole row of cells.
    const int n = 2 * kr_ + 1;
    auto rows = [&](int b) {
        for (int cy = bandStart(b, ch_); cy < bandStart(b + 1, ch_); ++cy) {
            float* out = spread_.row(cy);
            std::fill(out, out + cw_, 0.0f);
            for (int j = -kr_; j <= kr_; ++j) {
                const int sy = cy - j;
                if (sy < 0 || sy >= ch_) continue;
                const float* src = cells_.row(sy);
                for (int i = -kr_; i <= kr_; ++i) {
                    const float k = kernel_[static_cast<std::size_t>((j + kr_) * n + (i + kr_))];
                    if (k == 0.0f) continue;
                    const int x0 = std::max(0, i), x1 = std::min(cw_, cw_ + i);
                    if (x1 > x0) haloTapKernel(out + x0, src + (x0 - i), k, x1 - x0);
                }
            }
        }
    };
    forEachIndex(exec, kChainSlots, rows);
}

void HaloStage::addBackRow(float* r, int y) noexcept {
    addBackRow(r, r, y);
}

void HaloStage::addBackRow(const float* r, float* out, int y) noexcept {
    // 3. Back onto the pixels: a cell's halo share evenly over its pixels.
    const int fullCells = w_ / kBlock;
    const float keep = 1.0f - fraction_;
    const float share = fraction_ / static_cast<float>(kBlock * kBlock);
    const float* sp = spread_.row(y / kBlock);
    if (r == out)
        haloAddBack4(out, sp, fullCells, keep, share);
    else
        haloAddBack4To(r, out, sp, fullCells, keep, share);
    for (int x = fullCells * kBlock; x < w_; ++x)
        out[x] = keep * r[x] + share * sp[fullCells];
}

BspStage::BspStage(const CameraParams& c)
    : enabled_(c.agc == AgcMode::Bsp), knee_A_(c.bsp_knee_A), exponent_(c.bsp_exponent) {}

double BspStage::factor(double current_A) const noexcept {
    if (!enabled_ || !(current_A > 0.0)) return 1.0;
    // The series resistor R drops V = R·I from the cathode-MCP voltage; near the knee the
    // collection and gain fall together. A smooth 1/(1 + (I/I_knee)^p) keeps the measured
    // behaviour (gain constant at low current, ∝ 1/I above the knee) with two parameters.
    return 1.0 / (1.0 + std::pow(current_A / knee_A_, exponent_));
}

// ---- 5. MCP ---------------------------------------------------------------------------------

McpStage::McpStage(const CameraParams& c, std::uint64_t seed, GammaTableCache& gammaTables)
    : enabled_(c.mcp_enabled),
      noise_(c.mcp_noise && c.mcp_noise_factor > 1.0 + 1e-9),
      k_(c.mcp_noise_factor > 1.0 + 1e-9 ? 1.0 / (c.mcp_noise_factor - 1.0) : 0.0),
      seed_(seed),
      table_(enabled_ && noise_ ? gammaTables.forShapeStep(k_) : nullptr),
      stride_(paddedRow(c.width)),
      words_(new std::uint32_t[kChainSlots * stride_]),
      idx_(new int[kChainSlots * stride_]),
      blocks_(new std::uint32_t[kChainSlots * stride_]),
      uWords_(new std::uint32_t[kChainSlots * stride_]),
      n_(new float[kChainSlots * stride_]),
      e_(new float[kChainSlots * stride_]),
      rest_(new int[kChainSlots * stride_]),
      restN_(new float[kChainSlots * stride_]),
      heads_(new std::uint32_t[kChainSlots * 4 * stride_]),
      z_(new float[kChainSlots * stride_]),
      g_(new double[kChainSlots * stride_]) {}

void McpStage::apply(ImageView<float> pe, FieldContext& ctx) noexcept {
    begin(ctx);
    double total = 0.0;
    for (int y = 0; y < pe.height(); ++y)
        total += applyRow(pe.row(y), pe.width(), y);
    ctx.mcpOut_e = total;
}

void McpStage::begin(const FieldContext& ctx) noexcept {
    gain_ = ctx.mcpGain;
    field_ = ctx.field;
}

double McpStage::applyRow(float* __restrict v, int w, int y, int slot, bool sum) noexcept {
    const double g = gain_;
    if (!noise_) return mcpMeanKernel(v, w, static_cast<float>(g));
    // The gain of one electron has mean G and variance (F − 1)G²: a Gamma(k, G/k) with
    // k = 1/(F − 1). N independent ones sum to Gamma(N·k, G/k) exactly. Pixels with N = 0
    // draw nothing. Pixel x takes word x of its row: for N = 1 … GammaTable::kMaxN (whole
    // numbers) the tabulated quantile at that word; beyond (or for a fractional N, which a
    // noise-free photocathode passes on) Marsaglia–Tsang from the pixel's own stream, its first
    // attempt in a vector pass. The row's words are made for the whole row when many pixels
    // draw, for the drawing pixels' blocks alone when few do: the same words either way.
    int m = countPositive(v, w);
    if (m == 0) return 0.0;
    const PixelRng rng(seed_, RngStream::McpGain, field_);
    const std::uint32_t yy = static_cast<std::uint32_t>(y);
    const double theta = g / k_;
    const std::size_t off = static_cast<std::size_t>(slot) * stride_;
    int* __restrict idx = idx_.get() + off;
    std::uint32_t* __restrict wz = words_.get() + off;
    float* __restrict e = e_.get() + off;
    std::uint32_t* __restrict headsAll = heads_.get() + 4 * off;
    const bool dense = 4 * m > w;
    if (dense) {
        // Most pixels draw: the whole row at once (those with N = 0 get 0).
        rng.rowWords(yy, 0, 0, blocksFor(w), wz);
        gammaTableDraws(*table_, v, wz, e, w, static_cast<float>(theta));
        m = w;
    } else {
        // Few draw: those alone, gathered, their words from their own blocks.
        m = 0;
        for (int x = 0; x < w; ++x) {
            idx[m] = x;
            m += v[x] > 0.0f ? 1 : 0;
        }
        std::uint32_t* __restrict uw = uWords_.get() + off;
        float* __restrict n = n_.get() + off;
        std::uint32_t* __restrict b = blocks_.get() + off;
        for (int j = 0; j < m; ++j)
            b[j] = static_cast<std::uint32_t>(idx[j] / 4);
        rng.blocksAt(yy, 0, b, m, headsAll);
        for (int j = 0; j < m; ++j) {
            uw[j] = headsAll[static_cast<std::size_t>(4 * j + idx[j] % 4)];
            n[j] = v[idx[j]];
        }
        gammaTableDraws(*table_, n, uw, e, m, static_cast<float>(theta));
    }
    // The pixels past the table (e = −1): rare, so the chunks without one are passed over.
    int* __restrict rest = rest_.get() + off;
    int nRest = 0;
    const int scan = countNegative(e, m) == 0 ? 0 : m;  // none past the table: no list
    for (int j0 = 0; j0 < scan; j0 += 16) {
        const int len = std::min(16, scan - j0);
        if (countNegative(e + j0, len) == 0) continue;
        for (int l = 0; l < len; ++l) {
            rest[nRest] = j0 + l;
            nRest += e[j0 + l] < 0.0f ? 1 : 0;
        }
    }
    if (nRest > 0) {
        // Each one's stream head (made in bulk): word 0 gives the normal, word 1 the squeeze's
        // uniform; the first attempt in a vector pass, the rest one pixel at a time.
        std::uint32_t* __restrict xs = blocks_.get() + off;  // their pixels
        for (int r = 0; r < nRest; ++r)
            xs[r] = static_cast<std::uint32_t>(dense ? rest[r] : idx[rest[r]]);
        std::uint32_t* __restrict heads = headsAll;
        rng.streamHeads(yy, xs, nRest, heads);
        // Their normal and uniform words, in the buffers of the words the table draws used.
        std::uint32_t* __restrict zw = wz;
        std::uint32_t* __restrict u1 = uWords_.get() + off;
        float* __restrict rn = restN_.get() + off;
        for (int r = 0; r < nRest; ++r) {
            zw[r] = heads[4 * r];
            u1[r] = heads[4 * r + 1];
            rn[r] = v[xs[r]];
        }
        float* __restrict z = z_.get() + off;
        normalsFromWords(zw, z, nRest);
        double* __restrict first = g_.get() + off;
        gammaFirstAttemptKernel(rn, z, u1, first, nRest, k_, theta);
        for (int r = 0; r < nRest; ++r) {
            double ej = first[r];
            if (ej == 0.0) {
                PixelStream more(rng.pixelStream(xs[r], yy), heads + 4 * r, 2);
                ej = gammaFromNormal(static_cast<double>(rn[r]) * k_, theta, z[r], u1[r], more);
            }
            e[rest[r]] = static_cast<float>(ej);
        }
    }
    if (dense) {
        std::copy(e, e + w, v);
        return sum ? rowSumOf(v, w) : 0.0;
    }
    for (int j = 0; j < m; ++j)
        v[idx[j]] = e[j];
    return sum ? rowSumOf(e, m) : 0.0;
}

namespace {

// MCP saturation of one row (stage 5b): out = Q·(1 − e^(−D/Q)), Q → Q_max − (Q_max − Q +
// out)·keep.
// One channel: out = Q·(1 − e^(−D/Q)); a drained one (Q = 0) gives nothing (u held at 87
// gives Q·1 = 0, with no branch).
// Small: the caller knows u < 1/2.
template <bool Small>
__attribute__((always_inline)) inline float mcpSaturationPixel(float& d, float& q, float qMax,
                                                               float keep) noexcept {
    const float avail = q;
    const float u = std::min(d / std::max(avail, 1e-30f), 87.0f);
    const float out = avail * (Small ? oneMinusExpNegSmall(u) : oneMinusExpNeg(u));
    d = out;
    q = qMax - (qMax - avail + out) * keep;
    return out;
}

NVS_ROW_CLONES double mcpSaturationKernel(float* __restrict e, float* __restrict q, int w,
                                          float qMax, float keep) noexcept {
    constexpr int kL = 16;
    float acc[kL] = {};
    int x = 0;
    for (; x + kL <= w; x += kL) {
        // Where no channel of the 16 takes half its charge or more (u < 1/2, the usual case
        // below saturation), 1 − e^(−u) is its Taylor branch alone: the same values without
        // forming the exponential branch.
        int big = 0;
        for (int j = 0; j < kL; ++j)
            big += e[x + j] >= 0.5f * q[x + j] ? 1 : 0;
        if (big == 0) {
            for (int j = 0; j < kL; ++j)
                acc[j] += mcpSaturationPixel<true>(e[x + j], q[x + j], qMax, keep);
        } else {
            for (int j = 0; j < kL; ++j)
                acc[j] += mcpSaturationPixel<false>(e[x + j], q[x + j], qMax, keep);
        }
    }
    for (; x < w; ++x)
        acc[x % kL] += mcpSaturationPixel<false>(e[x], q[x], qMax, keep);
    double sum = 0.0;
    for (int j = 0; j < kL; ++j)
        sum += static_cast<double>(acc[j]);
    return sum;
}

}  // namespace

// ---- 5b. MCP local saturation ----------------------------------------------------------------

McpSaturationStage::McpSaturationStage(const CameraParams& c)
    : enabled_(c.mcpsat_enabled), tau_s_(c.mcpsat_recharge_s) {
    if (!enabled_) return;
    qMax_ = static_cast<float>(c.mcpsat_pixel_charge_e);
    q_ = ImageF(c.width, c.height);
    reset();
}

void McpSaturationStage::reset() noexcept {
    if (!q_.empty()) q_.fill(qMax_);
}

void McpSaturationStage::begin(const FieldContext& ctx) noexcept {
    if (!enabled_) return;
    keep_ = static_cast<float>(std::exp(-ctx.period_s / tau_s_));
}

double McpSaturationStage::applyRow(float* __restrict e, int w, int y) noexcept {
    return mcpSaturationKernel(e, q_.row(y), w, qMax_, keep_);
}

// ---- 6. Phosphor ----------------------------------------------------------------------------

double PhosphorStage::inPeriodFraction(double tau_s, double gate_s, double period_s) {
    // An impulse at t0 is emitted as exp(−(t − t0)/τ)/τ; by the period's end T it has given
    // 1 − exp(−(T − t0)/τ). Averaged over t0 uniform in [0, g]:
    //   f = 1 − exp(−T/τ)·(exp(g/τ) − 1)/(g/τ) = 1 − exp(−(T − g)/τ)·(1 − exp(−g/τ))/(g/τ),
    // the second form finite for τ ≪ g (the first is 0·∞ there).
    const double x = gate_s / tau_s;
    const double ratio = x < 1e-12 ? 1.0 : -std::expm1(-x) / x;
    const double tail = std::exp(-(period_s - (x < 1e-12 ? 0.0 : gate_s)) / tau_s) * ratio;
    return std::clamp(1.0 - tail, 0.0, 1.0);
}

PhosphorStage::PhosphorStage(const CameraParams& c)
    : enabled_(c.phosphor_enabled),
      eta_(c.ccdElectronsPerMcpElectron()),
      period_s_(c.integrationPeriod_s()) {
    if (!enabled_) return;
    n_ = static_cast<int>(c.phosphor_decay_s.size());
    for (int i = 0; i < n_; ++i) {
        tau_s_[i] = c.phosphor_decay_s[static_cast<std::size_t>(i)];
        weight_[i] = c.phosphor_weight[static_cast<std::size_t>(i)];
        // Excitation late in a period glows on into the next: a fraction up to
        // (τ/T)(1 − e^(−T/τ)) ≈ τ/T for a full-period gate. A component whose carried share
        // is below 1e-7 needs no state and costs nothing.
        const double carried = std::min(1.0, tau_s_[i] / c.integrationPeriod_s());
        stored_[i] = carried * weight_[i] > 1e-7;
    }
    int stored = 0;
    for (int i = 0; i < n_; ++i)
        stored += stored_[i] ? 1 : 0;
    if (stored > 0) {
        const int wBlocks = (c.width + kPhosphorBlock - 1) / kPhosphorBlock * kPhosphorBlock;
        state_ = ImageF(stored * wBlocks, c.height);
        state_.fill(0.0f);
    }
    row_.reset(new float[paddedRow(c.width)]);
}

void PhosphorStage::reset() noexcept {
    if (!state_.empty()) state_.fill(0.0f);
    if (!half_.empty()) half_.fill(0);
}

void PhosphorStage::boundInput(double maxIn) {
    if (state_.empty() || !(maxIn > 0.0)) return;
    // Component i's store after any number of periods: s ← s·d + e·k with e ≤ maxIn and
    // k = w(1 − f)·η ≤ w·η, so s ≤ maxIn·w·η/(1 − d) (d = e^(−T/τ), the period fixed). Its
    // scale: the power of two that puts that bound at or below 2^14 (a quarter of binary16's
    // range: room for the roundings); below 2^−14·scale the half values are subnormal, an
    // absolute step of 2^−24·scale.
    int m = 0;
    for (int i = 0; i < n_; ++i) {
        if (!stored_[i]) continue;
        double d = std::exp(-period_s_ / tau_s_[i]);
        if (d < 1e-20) d = 0.0;
        const double bound = maxIn * weight_[i] * eta_ / (1.0 - d);
        const int e2 = bound > 0.0 ? static_cast<int>(std::ceil(std::log2(bound / 16384.0))) : 0;
        scale_[m] = std::ldexp(1.0f, e2);
        invScale_[m] = std::ldexp(1.0f, -e2);
        ++m;
    }
    half_ = ImageU16(state_.width(), state_.height());
    half_.fill(0);
    state_ = ImageF();
}

void PhosphorStage::apply(ImageView<float> s, const FieldContext& ctx) noexcept {
    if (!enabled_) return;
    begin(ctx);
    const int w = s.width();
    for (int y = 0; y < s.height(); ++y) {
        float* v = s.row(y);
        std::copy(v, v + w, row_.get());
        applyRow(row_.get(), v, w, y);
    }
}

void PhosphorStage::begin(const FieldContext& ctx) noexcept {
    if (!enabled_) return;
    float now = 0.0f;  // fraction of this period's excitation seen in this period
    m_ = 0;
    for (int i = 0; i < n_; ++i) {
        const double f = inPeriodFraction(tau_s_[i], ctx.gate_s, ctx.period_s);
        if (!stored_[i]) {
            now += static_cast<float>(weight_[i]);  // emitted at once, to within 1e-7
            continue;
        }
        now += static_cast<float>(weight_[i] * f);
        // Below 1e-20 a period's decay factor is 0: the store is all emitted in the next
        // period (kPhosphorFloor_e needs decay factors that are 0 or ≥ 1e-20).
        double d = std::exp(-ctx.period_s / tau_s_[i]);
        if (d < 1e-20) d = 0.0;
        idx_[m_] = i;
        keepEta_[m_] = static_cast<float>(weight_[i] * (1.0 - f)) * static_cast<float>(eta_);
        decay_[m_] = static_cast<float>(d);
        emit_[m_] = static_cast<float>(1.0 - d);
        ++m_;
    }
    nowEta_ = now * static_cast<float>(eta_);
}

void PhosphorStage::applyRow(const float* in, float* out, int w, int y) noexcept {
    if (!half_.empty()) {
        // phosphorHasAvx512() is false where the AVX-512 form is not built or cannot run.
        std::uint16_t* st = half_.row(y);
        (detail::phosphorHasAvx512() ? detail::phosphorRowHalfAvx512 : detail::phosphorRowHalf)(
            in, out, st, w, m_, nowEta_, keepEta_, decay_, emit_, scale_, invScale_);
        return;
    }
    float* st = state_.empty() ? nullptr : state_.row(y);
    switch (m_) {
        case 0:
            phosphorRow0(in, out, st, w, nowEta_, keepEta_, decay_, emit_);
            break;
        case 1:
            phosphorRow1(in, out, st, w, nowEta_, keepEta_, decay_, emit_);
            break;
        case 2:
            phosphorRow2(in, out, st, w, nowEta_, keepEta_, decay_, emit_);
            break;
        case 3:
            phosphorRow3(in, out, st, w, nowEta_, keepEta_, decay_, emit_);
            break;
        default:
            phosphorRow4(in, out, st, w, nowEta_, keepEta_, decay_, emit_);
            break;
    }
}

// ---- 7. Blur --------------------------------------------------------------------------------

struct BlurStage::Fft {
    float* real = nullptr;
    float* slotRows = nullptr;  // kChainSlots rows of wp_ floats, one a band (slotRow)
    fftwf_complex* spec = nullptr;
    float* filter = nullptr;
    fftwf_plan rowFwd = nullptr;  // one row, r2c, real row → spectrum row
    fftwf_plan rowInv = nullptr;  // one row, c2r, spectrum row → real row
    fftwf_plan colFwd[2] = {};    // a band of columns, in place: a full band, the last band
    fftwf_plan colInv[2] = {};
    ~Fft() {
        for (fftwf_plan p : {rowFwd, rowInv, colFwd[0], colFwd[1], colInv[0], colInv[1]})
            if (p) fftwf_destroy_plan(p);
        fftwf_free(real);
        fftwf_free(slotRows);
        fftwf_free(spec);
        fftwf_free(filter);
    }
};

namespace {
// FFT length for an image dimension m with a mirrored margin of at least kMinMargin px on
// each side: the first multiple of 32 with prime factors 2, 3, 5, 7 within 64 px of the
// minimum (FFTW is fastest on these: 800 × 512 for 768 × 494 takes 1.7 ms against 2.5 ms
// for 800 × 540), else the first 7-smooth length.
constexpr int kMinMargin = 8;
bool smooth7(int n) {
    for (int p : {2, 3, 5, 7})
        while (n % p == 0)
            n /= p;
    return n == 1;
}
int fastSize(int m) {
    const int lo = std::max(m + 2 * kMinMargin, 1);
    for (int n = (lo + 31) / 32 * 32; n <= lo + 64; n += 32)
        if (smooth7(n)) return n;
    for (int n = lo;; ++n)
        if (smooth7(n)) return n;
}
// Mirror index for padding: positions past the right edge mirror it; positions near the
// (periodic) end mirror the left edge, the two mirrors meeting half-way.
inline int padIndex(int i, int n, int np) {
    if (i < n) return i;
    const int beyond = i - n;
    const int half = (np - n) / 2;
    int j = beyond < half ? n - 1 - beyond : np - i - 1;  // np - i - 1: mirror of x = 0 side
    return std::clamp(j, 0, n - 1);
}
}  // namespace

namespace {
// The shipped wisdom (config/fftw/, made by tests/sim/sensor/make_wisdom.sh): the blur's plans
// for the shipped presets' sizes and 1280 x 1024, the same plans on every x86-64 CPU, so that
// the blur gives the same bits everywhere (docs/portability.md). Two facts of FFTW shape it:
// - a plan names codelets, and wisdom that names AVX codelets gives no plan on a CPU without
//   AVX: the plans are made as a CPU with SSE4.2 only (qemu-user, -cpu Nehalem-v2), so they use
//   SSE2 codelets, which every x86-64 CPU has;
// - FFTW takes a wisdom file only when its header's hash of the solvers registered matches the
//   running CPU's, and CPUs with AVX register other solvers than CPUs without: the same plans
//   ship twice, under each header (wisdom-single.txt for CPUs with AVX, wisdom-single-sse.txt
//   for those without); FFTW rejects the other file whole.
// Where no wisdom holds the problem (another size), FFTW_ESTIMATE among the scalar solvers
// (FFTW_NO_SIMD, one of fftw3.h's planner flags): the estimate among SIMD solvers depends on
// the CPU. Measured on this machine's AVX2 CPU against qemu-user as Nehalem-v2: plans from AVX
// wisdom, or SSE2 wisdom under one header only, gave frames a few pixels apart by one count;
// these gave identical frames (tests/isa).
// Imported by every BlurStage before it plans, from the config folder it was given: the wisdom
// lives in FFTW's own planner, and importing the same file again replaces each entry with
// itself (FFTW's hash table overwrites an entry of the same problem and flags), so repeating it
// changes no plan; it also puts back the shipped entries should an FFTW_MEASURE plan have
// replaced one. Not thread-safe, like FFTW's planner itself: chains are made on one thread.
void importShippedWisdom(const std::filesystem::path& configDir) {
    for (const char* name : {"wisdom-single.txt", "wisdom-single-sse.txt"}) {
        const std::filesystem::path file = configDir / "fftw" / name;
        if (pathExists(file)) fftwf_import_wisdom_from_filename(file.c_str());
    }
}
}  // namespace

namespace {
// A plan from the flags asked for; with FFTW_WISDOM_ONLY and no wisdom for the problem,
// FFTW_ESTIMATE's among the scalar solvers (above): the same plan, and so the same bits, on
// every CPU.
template <class MakePlan>
fftwf_plan planOrEstimate(MakePlan&& make, unsigned flags) {
    fftwf_plan p = make(flags);
    if (!p && (flags & FFTW_WISDOM_ONLY)) p = make(FFTW_ESTIMATE | FFTW_NO_SIMD);
    if (!p) throw SetupError("blur: FFTW could not plan");
    return p;
}
// Columns of the spectrum per band: kBlurColumnBands bands, on whole 64-byte lines.
int columnBandWidth(int wc) {
    const int perBand = (wc + kBlurColumnBands - 1) / kBlurColumnBands;
    return (perBand + 7) / 8 * 8;
}
}  // namespace

BlurStage::BlurStage(const CameraParams& c, const ChainOptions& opt,
                     const std::filesystem::path& configDir)
    : enabled_(c.mtf_enabled), w_(c.width), h_(c.height) {
    if (!enabled_) return;
    // A margin of at least 8 px mirrored on each side keeps the periodic FFT from wrapping
    // the opposite edge into the image (for 768 × 494: 16 px left/right, 9 px top/bottom).
    wp_ = fastSize(w_);
    hp_ = fastSize(h_);
    fft_ = std::make_unique<Fft>();
    // The 2-d transform as its two passes, so that bands of rows and bands of columns can run
    // at once: a 1-d r2c of each row, then a 1-d FFT down each column of the half spectrum
    // (rows of wcs_ ≥ wp/2 + 1 complex, on whole 64-byte lines, so that every row and every
    // column band has the alignment the plans were made for).
    wc_ = wp_ / 2 + 1;
    wcs_ = (wc_ + 7) / 8 * 8;
    cb_ = columnBandWidth(wc_);
    const std::size_t nr = static_cast<std::size_t>(wp_) * static_cast<std::size_t>(hp_);
    const std::size_t nc = static_cast<std::size_t>(wcs_) * static_cast<std::size_t>(hp_);
    fft_->real = fftwf_alloc_real(nr);
    fft_->spec = fftwf_alloc_complex(nc);
    fft_->filter = fftwf_alloc_real(nc);
    slotStride_ = (wp_ + 15) / 16 * 16;  // whole 64-byte lines: every slot row as aligned
    const std::size_t ns =
        static_cast<std::size_t>(kChainSlots) * static_cast<std::size_t>(slotStride_);
    fft_->slotRows = fftwf_alloc_real(ns);
    if (!fft_->real || !fft_->spec || !fft_->filter || !fft_->slotRows)
        throw SetupError("blur: out of memory");
    std::fill(fft_->real, fft_->real + nr, 0.0f);
    std::fill(fft_->slotRows, fft_->slotRows + ns, 0.0f);
    std::fill(fft_->filter, fft_->filter + nc, 0.0f);
    // Plans: from the shipped wisdom where it holds the problem (SSE2 codelets, the same on
    // every CPU), else FFTW_ESTIMATE's among scalar solvers; FFTW_MEASURE / FFTW_PATIENT on request
    // only (a measured plan can differ from run to run and so break bit-exact replay).
    importShippedWisdom(configDir);
    const unsigned flags = opt.patientFft   ? FFTW_PATIENT
                           : opt.measureFft ? FFTW_MEASURE
                                            : FFTW_MEASURE | FFTW_WISDOM_ONLY;
    planTransforms(flags);
    // The filter: the product of the stage MTFs at each DFT frequency, converted from cycles
    // per pixel to cycles per mm at the cathode; 1/(wp·hp) normalises FFTW's round trip.
    const double px = cathodePitchX_mm(c);
    const double py = cathodePitchY_mm(c);
    const double norm = 1.0 / static_cast<double>(nr);
    for (int ky = 0; ky < hp_; ++ky) {
        const double fy = (ky <= hp_ / 2 ? ky : ky - hp_) / static_cast<double>(hp_) / py;
        for (int kx = 0; kx < wc_; ++kx) {
            const double fx = kx / static_cast<double>(wp_) / px;
            fft_->filter[static_cast<std::size_t>(ky) * wcs_ + kx] =
                static_cast<float>(systemMtf(c, fx, fy) * norm);
        }
    }
}

void BlurStage::planTransforms(unsigned flags) {
    float* r = fft_->real;
    fftwf_complex* sp = fft_->spec;
    fft_->rowFwd =
        planOrEstimate([&](unsigned f) { return fftwf_plan_dft_r2c_1d(wp_, r, sp, f); }, flags);
    fft_->rowInv =
        planOrEstimate([&](unsigned f) { return fftwf_plan_dft_c2r_1d(wp_, sp, r, f); }, flags);
    // Column bands: cb_ columns each, the last one what is left.
    const int last = wc_ - (wc_ - 1) / cb_ * cb_;
    for (int i = 0; i < 2; ++i) {
        int n[1] = {hp_};
        const int howmany = i == 0 ? cb_ : last;
        for (int sign : {FFTW_FORWARD, FFTW_BACKWARD}) {
            fftwf_plan p = planOrEstimate(
                [&](unsigned f) {
                    return fftwf_plan_many_dft(1, n, howmany, sp, nullptr, wcs_, 1, sp, nullptr,
                                               wcs_, 1, sign, f);
                },
                flags);
            (sign == FFTW_FORWARD ? fft_->colFwd : fft_->colInv)[i] = p;
        }
    }
}

BlurStage::~BlurStage() = default;

bool BlurStage::exportWisdom(const std::filesystem::path& file) {
    return fftwf_export_wisdom_to_filename(file.c_str()) != 0;
}

void BlurStage::apply(ImageView<float> img) noexcept {
    if (!enabled_) return;
    for (int y = 0; y < h_; ++y) {
        const float* src = img.row(y);
        std::copy(src, src + w_, inputRow(y));
    }
    filter();
    for (int y = 0; y < h_; ++y) {
        const float* src = outputRow(y);
        float* dst = img.row(y);
        for (int x = 0; x < w_; ++x)
            dst[x] = std::max(src[x], 0.0f);  // ringing below zero is not charge
    }
}

float* BlurStage::inputRow(int y) noexcept {
    return fft_->real + static_cast<std::ptrdiff_t>(y) * wp_;
}

const float* BlurStage::outputRow(int y) const noexcept {
    return fft_->real + static_cast<std::ptrdiff_t>(y) * wp_;
}

namespace {
NVS_ROW_CLONES void applyFilterKernel(fftwf_complex* __restrict s, const float* __restrict f,
                                      int rows, int n, std::ptrdiff_t stride) noexcept {
    // rows × n complex values of a band of columns (row stride `stride` complex), each times
    // its real MTF value.
    for (int y = 0; y < rows; ++y) {
        float* __restrict p = reinterpret_cast<float*>(s + y * stride);
        const float* __restrict fy = f + y * stride;
        for (int i = 0; i < n; ++i) {
            p[2 * i] *= fy[i];
            p[2 * i + 1] *= fy[i];
        }
    }
}
}  // namespace

void BlurStage::filter() noexcept {
    SerialExecutor serial;
    filter(serial);
}

void BlurStage::filter(RowExecutor& exec) noexcept {
    if (!enabled_) return;
    // 1. Bands of image rows: the mirrored margin past each row's end, then its r2c.
    auto rowsForward = [&](int b) {
        for (int y = bandStart(b, h_); y < bandStart(b + 1, h_); ++y)
            forwardRow(y);
    };
    forEachIndex(exec, kChainSlots, rowsForward);
    // 2. Bands of columns.
    filterColumns(exec);
    // 3. Bands of image rows again: the c2r of each.
    auto rowsInverse = [&](int b) {
        for (int y = bandStart(b, h_); y < bandStart(b + 1, h_); ++y)
            inverseRow(y);
    };
    forEachIndex(exec, kChainSlots, rowsInverse);
}

void BlurStage::forwardRow(int y) noexcept {
    forwardRow(fft_->real + static_cast<std::ptrdiff_t>(y) * wp_, y);
}

float* BlurStage::slotRow(int slot) noexcept {
    return fft_->slotRows + static_cast<std::ptrdiff_t>(slot) * slotStride_;
}

void BlurStage::forwardRow(float* row, int y) noexcept {
    // `row` has the alignment the plan was made for: the slot rows start whole 64-byte lines
    // from an fftwf_alloc_real base, as the real buffer's first row does.
    for (int x = w_; x < wp_; ++x)
        row[x] = row[padIndex(x, w_, wp_)];
    fftwf_execute_dft_r2c(fft_->rowFwd, row, fft_->spec + static_cast<std::ptrdiff_t>(y) * wcs_);
}

void BlurStage::filterColumns(RowExecutor& exec) noexcept {
    if (!enabled_) return;
    // The rows past the image mirror image rows, and so do their spectra (copied); then the
    // column FFT, the MTF and the inverse column FFT, band by band.
    const int bands = (wc_ + cb_ - 1) / cb_;
    auto columns = [&](int b) {
        const int c0 = b * cb_;
        const int n = std::min(cb_, wc_ - c0);
        for (int y = h_; y < hp_; ++y) {
            const float* src =
                &fft_->spec[static_cast<std::ptrdiff_t>(padIndex(y, h_, hp_)) * wcs_ + c0][0];
            std::copy(src, src + 2 * n, &fft_->spec[static_cast<std::ptrdiff_t>(y) * wcs_ + c0][0]);
        }
        const int which = n == cb_ ? 0 : 1;
        fftwf_complex* col = fft_->spec + c0;
        fftwf_execute_dft(fft_->colFwd[which], col, col);
        applyFilterKernel(col, fft_->filter + c0, hp_, n, wcs_);
        fftwf_execute_dft(fft_->colInv[which], col, col);
    };
    forEachIndex(exec, bands, columns);
}

void BlurStage::inverseRow(int y) noexcept {
    inverseRow(y, fft_->real + static_cast<std::ptrdiff_t>(y) * wp_);
}

void BlurStage::inverseRow(int y, float* row) noexcept {
    fftwf_execute_dft_c2r(fft_->rowInv, fft_->spec + static_cast<std::ptrdiff_t>(y) * wcs_, row);
}

// ---- 8. CCD ---------------------------------------------------------------------------------

CcdStage::CcdStage(const CameraParams& c, std::uint64_t seed)
    : cam_(&c),
      seed_(seed),
      line_(new float[static_cast<std::size_t>(2 * std::max(c.width, c.height) + 2)]),
      colSum_(new float[paddedRow(c.width)]),
      colMax_(new float[paddedRow(c.width)]),
      slotMax_(new float[kChainSlots * paddedRow(c.width)]),
      stride_(paddedRow(c.width)),
      words_(new std::uint32_t[kChainSlots * stride_]),
      z_(new float[kChainSlots * stride_]),
      row_(new float[paddedRow(c.width)]) {
    if (c.full_well_e > 0.0 && c.bloom == BloomDirection::Vertical)
        upCarry_ = ImageF(c.width, c.height);
    if (c.prnu_rel > 0.0) {
        // Fixed pattern: one draw per cell, keyed by field 0 so it is the same every field.
        prnu_ = ImageF(c.width, c.height);
        const PixelRng rng(seed, RngStream::FixedPattern, 0);
        for (int y = 0; y < c.height; ++y) {
            float* p = prnu_.row(y);
            rng.rowWords(static_cast<std::uint32_t>(y), 0, 0, blocksFor(c.width), words_.get());
            normalsFromWords(words_.get(), z_.get(), c.width);
            for (int x = 0; x < c.width; ++x)
                p[x] = static_cast<float>(1.0 + c.prnu_rel * static_cast<double>(z_[x]));
        }
    }
    const double video_e = c.video_noise_dc / c.video_gain_dc_per_e;
    noiseSigma_e_ = std::sqrt(c.read_noise_e * c.read_noise_e + video_e * video_e);
}

std::int64_t CcdStage::bloomLine(float* v, int n, std::ptrdiff_t step, float fw,
                                 float* carry) noexcept {
    // Appendix L spills a saturated cell's excess half to each side along the line, and the
    // spill that overfills a neighbour moves on. Its linear weights only shape how fast the
    // spill fills the nearest cells; here it fills them to full well outright (the limit of a
    // narrow spread) and the sweep is O(n) with charge conserved.
    bool any = false;
    for (int i = 0; i < n; ++i) {
        const float e = v[i * step] - fw;
        if (e > 0.0f) {
            any = true;
            carry[i] = 0.5f * e;  // to the right / down
            v[i * step] = fw;
        } else {
            carry[i] = 0.0f;
        }
    }
    if (!any) return 0;
    float* left = carry + n;
    for (int i = 0; i < n; ++i)
        left[i] = carry[i];
    float moving = 0.0f;
    for (int i = 0; i < n; ++i) {
        float& c = v[i * step];
        if (moving > 0.0f) {
            const float room = fw - c;
            const float take = std::min(room, moving);
            c += take;
            moving -= take;
        }
        moving += carry[i];
    }
    moving = 0.0f;
    for (int i = n - 1; i >= 0; --i) {
        float& c = v[i * step];
        if (moving > 0.0f) {
            const float room = fw - c;
            const float take = std::min(room, moving);
            c += take;
            moving -= take;
        }
        moving += left[i];
    }
    std::int64_t sat = 0;
    for (int i = 0; i < n; ++i)
        sat += v[i * step] >= fw ? 1 : 0;
    return sat;
}

namespace {
// bloomLine's sweeps for every column at once, row by row (cache-friendly, vector code): down
// the columns each cell over full well keeps fw, sends half its excess down (filling cells
// below to fw on the way) and stores the other half (up); then up the columns the stored
// halves fill the cells above. A column below full well carries nothing and is unchanged, as
// in bloomLine. Value selects (not std::min/max, which return references) keep the loops
// branch-free.
NVS_ROW_CLONES void bloomDownKernel(float* __restrict v, float* __restrict moving,
                                    float* __restrict up, int n, float fw) noexcept {
    for (int i = 0; i < n; ++i) {
        // d = c − fw: excess max(d, 0) = (d + |d|)/2 and room max(−d, 0) = (|d| − d)/2, both
        // exact in floating point; min(c, fw) = c − excess.
        const float c = v[i];
        const float m = moving[i];
        const float d = c - fw;
        const float ad = std::fabs(d);
        const float excess = 0.5f * (d + ad);
        const float room = 0.5f * (ad - d);
        const float take = room < m ? room : m;
        v[i] = (c - excess) + take;
        moving[i] = m + (0.5f * excess - take);
        up[i] = 0.5f * excess;
    }
}

// The up sweep leaves the final charge: it also adds it to the column sums and counts the
// cells at full well.
NVS_ROW_CLONES int bloomUpKernel(float* __restrict v, float* __restrict moving,
                                 const float* __restrict up, float* __restrict cs, int n,
                                 float fw) noexcept {
    int sat = 0;
    for (int i = 0; i < n; ++i) {
        const float r = fw - v[i];
        const float room = r > 0.0f ? r : 0.0f;
        const float take = room < moving[i] ? room : moving[i];
        const float c = v[i] + take;
        v[i] = c;
        moving[i] += up[i] - take;
        sat += static_cast<int>(c >= fw);
        cs[i] += c;
    }
    return sat;
}
}  // namespace

std::int64_t CcdStage::bloomColumns(ImageView<float> e, float fw, const float* cmax,
                                    float* colSum) noexcept {
    // The down sweep was made row by row in loadRow(); the up sweep over the span of columns
    // that reached full well (the others are unchanged), their column sums formed anew.
    const int w = e.width();
    const int h = e.height();
    int x0 = 0, x1 = w;
    while (x0 < w && cmax[x0] < fw)
        ++x0;
    while (x1 > x0 && cmax[x1 - 1] < fw)
        --x1;
    if (x0 >= x1) return 0;
    const int n = x1 - x0;
    float* __restrict moving = line_.get();
    std::fill(moving, moving + n, 0.0f);
    float* __restrict cs = colSum ? colSum + x0 : line_.get() + n;
    std::fill(cs, cs + n, 0.0f);
    std::int64_t sat = 0;
    for (int y = h - 1; y >= 0; --y)
        sat += bloomUpKernel(e.row(y) + x0, moving, upCarry_.row(y) + x0, cs, n, fw);
    return sat;
}

std::int64_t CcdStage::apply(ImageView<float> e, const FieldContext& ctx) noexcept {
    begin(ctx);
    for (int y = 0; y < e.height(); ++y)
        loadRow(e.row(y), e.row(y), y);
    const std::int64_t saturated = bloom(e);
    for (int y = 0; y < e.height(); ++y)
        finishRow(e.row(y), y);
    return saturated;
}

void CcdStage::begin(const FieldContext& ctx) noexcept {
    const CameraParams& c = *cam_;
    field_ = ctx.field;
    dark_e_ = static_cast<float>(c.dark_e_s * ctx.period_s);
    // Read noise, the dark charge's shot noise, and the video pre-amplifier noise referred
    // back to electrons, all additive and Gaussian, in one draw per cell.
    const double darkVar = static_cast<double>(dark_e_);
    sigma_e_ = static_cast<float>(std::sqrt(noiseSigma_e_ * noiseSigma_e_ + darkVar));
    // Read noise belongs to the rows read out: in field mode only this field's lines.
    readY0_ = c.scan == ScanMode::Field ? c.fieldRowParity(ctx.field) : 0;
    readDy_ = c.scan == ScanMode::Field ? 2 : 1;
    const int w = c.width;
    std::fill(colMax_.get(), colMax_.get() + w, 0.0f);
    std::fill(colSum_.get(), colSum_.get() + w, 0.0f);
    std::fill(line_.get() + w, line_.get() + 2 * w, 0.0f);  // loadRow's down sweep
}

void CcdStage::loadRow(const float* src, float* dst, int y) noexcept {
    // Fixed pattern and dark charge; the largest charge of each column (which columns need
    // the blooming sweep) and the column sums (smear).
    const int w = cam_->width;
    if (src == dst) {
        std::copy(src, src + w, row_.get());
        src = row_.get();
    }
    ccdLoadKernel(src, prnu_.empty() ? nullptr : prnu_.row(y), dst, colMax_.get(), colSum_.get(), w,
                  dark_e_);
    // Vertical blooming's down sweep, on the row while it is in cache (bloomColumns).
    if (!upCarry_.empty())
        bloomDownKernel(dst, line_.get() + w, upCarry_.row(y), w,
                        static_cast<float>(cam_->full_well_e));
}

void CcdStage::beginLoad() noexcept {
    const std::size_t n = kChainSlots * stride_;
    std::fill(slotMax_.get(), slotMax_.get() + n, 0.0f);
}

void CcdStage::loadRowMax(const float* src, float* dst, int y, int slot) noexcept {
    ccdLoadMaxKernel(src, prnu_.empty() ? nullptr : prnu_.row(y), dst,
                     slotMax_.get() + static_cast<std::size_t>(slot) * stride_, cam_->width,
                     dark_e_);
}

void CcdStage::finishLoad(ImageView<float> e) noexcept {
    const int w = cam_->width;
    float* __restrict cmax = colMax_.get();
    for (int s = 0; s < kChainSlots; ++s) {
        const float* m = slotMax_.get() + static_cast<std::size_t>(s) * stride_;
        for (int x = 0; x < w; ++x)
            cmax[x] = cmax[x] < m[x] ? m[x] : cmax[x];
    }
    // The column sums (smear only), down each column in row order as loadRow adds them.
    if (cam_->smear_rel > 0.0) {
        for (int y = 0; y < e.height(); ++y)
            addRowKernel(e.row(y), colSum_.get(), w);
    }
    // Vertical blooming's down sweep (loadRow's, after the loads: a row's sweep reads only its
    // own loaded values and the columns' carries), over the span of columns that reach full
    // well: elsewhere it changes nothing and bloomColumns reads nothing.
    if (upCarry_.empty()) return;
    const float fw = static_cast<float>(cam_->full_well_e);
    int x0 = 0, x1 = w;
    while (x0 < w && cmax[x0] < fw)
        ++x0;
    while (x1 > x0 && cmax[x1 - 1] < fw)
        --x1;
    if (x0 >= x1) return;
    float* moving = line_.get() + w;
    for (int y = 0; y < e.height(); ++y)
        bloomDownKernel(e.row(y) + x0, moving + x0, upCarry_.row(y) + x0, x1 - x0, fw);
}

std::int64_t CcdStage::bloom(ImageView<float> e) noexcept {
    const CameraParams& c = *cam_;
    const int w = e.width();
    const int h = e.height();
    const bool smear = c.smear_rel > 0.0;
    float* __restrict cs = colSum_.get();
    std::int64_t saturated = 0;
    if (c.full_well_e > 0.0) {
        const float fw = static_cast<float>(c.full_well_e);
        const float* cmax = colMax_.get();
        if (c.bloom == BloomDirection::Vertical) {
            saturated += bloomColumns(e, fw, cmax, smear ? cs : nullptr);
        } else {
            bool any = false;
            for (int x = 0; x < w; ++x)
                any = any || cmax[x] >= fw;
            float* carry = line_.get();
            for (int y = 0; any && y < h; ++y) {
                float* v = e.row(y);
                if (c.bloom == BloomDirection::Horizontal) {
                    saturated += bloomLine(v, w, 1, fw, carry);
                    continue;
                }
                for (int x = 0; x < w; ++x) {
                    if (v[x] >= fw) {
                        v[x] = fw;
                        ++saturated;
                    }
                }
            }
            if (any && smear) {  // charge moved along rows: the column sums again
                std::fill(cs, cs + w, 0.0f);
                for (int y = 0; y < h; ++y) {
                    const float* v = e.row(y);
                    for (int x = 0; x < w; ++x)
                        cs[x] += v[x];
                }
            }
        }
    }
    // Interline smear: light leaking into the vertical register while the column is clocked
    // out adds a fraction of the column's mean charge to every cell of it.
    if (smear) {
        const float k = static_cast<float>(c.smear_rel / h);
        for (int x = 0; x < w; ++x)
            cs[x] *= k;
    } else {
        std::fill(cs, cs + w, 0.0f);
    }
    return saturated;
}

void CcdStage::finishRow(float* v, int y, int slot) noexcept {
    const CameraParams& c = *cam_;
    const int w = c.width;
    const bool smear = c.smear_rel > 0.0;
    const float* cs = colSum_.get();
    const bool read = y >= readY0_ && (y - readY0_) % readDy_ == 0;
    if (!read) {
        if (smear) {
            for (int x = 0; x < w; ++x)
                v[x] += cs[x];
        }
        return;
    }
    if (sigma_e_ > 0.0f) {
        // One word per cell, inverse-CDF normals.
        const std::size_t off = static_cast<std::size_t>(slot) * stride_;
        std::uint32_t* words = words_.get() + off;
        float* z = z_.get() + off;
        const PixelRng rng(seed_, RngStream::ReadNoise, field_);
        rng.rowWords(static_cast<std::uint32_t>(y), 0, 0, blocksFor(w), words);
        normalsFromWords(words, z, w);
        ccdReadKernel(v, cs, z, w, sigma_e_);
    } else if (smear) {
        for (int x = 0; x < w; ++x)
            v[x] += cs[x];
    }
}

// ---- 9. Video -------------------------------------------------------------------------------

VideoStage::VideoStage(const CameraParams& c) : cam_(&c), maxCount_((1 << c.adc_bits) - 1) {
    gamma_ = std::fabs(c.gamma - 1.0) > 1e-9;
    if (!gamma_) return;
    // Output for a signal s > 0 (in DC before the offset): round(span·min(s/span, 1)^γ +
    // offset), clamped to [0, max]. It steps up by one at s_k = span·((k − ½ − offset)/span)^(1/γ)
    // for each level k above round(offset); thr_ holds those steps that lie in (0, span].
    const double maxc = maxCount_;
    const double offset = c.video_offset_dc;
    const double span = std::max(maxc - offset, 1.0);
    const double top = std::clamp(std::nearbyint(span + offset), 0.0, maxc);
    const double bottom = std::clamp(std::nearbyint(offset), 0.0, maxc);
    for (double k = bottom + 1.0; k <= top; k += 1.0) {
        const double r = (k - 0.5 - offset) / span;
        thr_.push_back(r <= 0.0 ? 0.0f : static_cast<float>(span * std::pow(r, 1.0 / c.gamma)));
    }
    // A uniform grid over [0, span] fine enough that no cell holds two steps (16 cells per
    // level to start, doubled where γ packs the low levels closer): then the level of a
    // signal is lut_[cell] plus one if the next step is at or below it, with no loop.
    int cells = 16 * static_cast<int>(thr_.size() + 1);
    for (;;) {
        lutScale_ = static_cast<float>(cells / span);
        lut_.assign(static_cast<std::size_t>(cells) + 1, 0);
        std::size_t j = 0, most = 0;
        for (int i = 0; i <= cells; ++i) {
            const float s = static_cast<float>(i) / lutScale_;
            const std::size_t j0 = j;
            while (j < thr_.size() && thr_[j] <= s)
                ++j;
            most = std::max(most, j - j0);
            lut_[static_cast<std::size_t>(i)] = static_cast<std::int32_t>(j);
        }
        oneStep_ = most <= 1;
        if (oneStep_ || cells >= (1 << 22)) break;
        cells *= 2;
    }
    thr_.push_back(3.0e38f);  // sentinel
}

double VideoStage::apply(ImageView<const float> e, std::uint64_t field, ImageView<float> counts,
                         ImageView<std::uint16_t> video) const noexcept {
    double sum = 0.0;
    std::int64_t n = 0;
    for (int y = 0; y < e.height(); ++y) {
        if (!readsRow(field, y)) continue;
        sum += static_cast<double>(applyRow(e.row(y), counts.row(y), video.row(y), e.width()));
        n += e.width();
    }
    return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

bool VideoStage::readsRow(std::uint64_t field, int y) const noexcept {
    return cam_->scan != ScanMode::Field || (y & 1) == cam_->fieldRowParity(field);
}

std::int64_t VideoStage::applyRow(const float* s, float* o, std::uint16_t* v,
                                  int w) const noexcept {
    const CameraParams& c = *cam_;
    const float gain = static_cast<float>(c.video_gain_dc_per_e);
    const float offset = static_cast<float>(c.video_offset_dc);
    const float maxc = static_cast<float>(maxCount_);
    const float bottom = std::clamp(std::nearbyint(offset), 0.0f, maxc);
    if (!gamma_) return videoLinearKernel(s, o, v, w, gain, offset, maxc);
    const int cells = static_cast<int>(lut_.size()) - 1;
    if (oneStep_) {
        return videoGammaKernel(s, o, v, w, gain, offset, maxc, lut_.data(), thr_.data(), lutScale_,
                                static_cast<float>(cells), bottom);
    }
    videoLinearKernel(s, o, v, w, gain, offset, maxc);
    std::int64_t sum = 0;
    for (int x = 0; x < w; ++x) {
        const float sig = s[x] * gain;
        if (sig > 0.0f) {
            const int cell = std::min(static_cast<int>(sig * lutScale_), cells);
            std::size_t j = lut_[static_cast<std::size_t>(cell)];
            while (thr_[j] <= sig)
                ++j;
            o[x] = std::min(bottom + static_cast<float>(j), maxc);
            v[x] = static_cast<std::uint16_t>(static_cast<std::int32_t>(o[x]));
        }
        sum += v[x];
    }
    return sum;
}

// ---- 10. AGC loop ---------------------------------------------------------------------------

AgcLoop::AgcLoop(const CameraParams& c) : cam_(&c) {
    reset();
}

void AgcLoop::reset() noexcept {
    start(cam_->gain_V);
}

void AgcLoop::start(double gain_V) noexcept {
    for (int i = 0; i < kRing; ++i) {
        gainRing_[i] = gain_V;
        gateRing_[i] = 1.0;
    }
    gainCmd_V_ = gain_V;
    gateCmd_ = 1.0;
}

void AgcLoop::update(const FieldContext& ctx, double level_dc) noexcept {
    const CameraParams& c = *cam_;
    if (c.agc == AgcMode::Off || c.agc == AgcMode::Bsp) return;
    const double signal = std::max(level_dc - c.video_offset_dc, 0.25);
    const double want = std::max(c.agc_target_dc - c.video_offset_dc, 0.25);
    int lag = std::max(c.agc_lag_fields, 1);
    if (c.agc == AgcMode::Agc) {
        // Video AGC: the gain that would bring this field's level to the target, approached
        // with a first-order lag of time constant τ, applied `lag` fields later.
        const double gNow = c.mcpGain(ctx.gain_V);
        const double vTarget = std::clamp(c.controlVoltageForGain(gNow * want / signal),
                                          c.agc_min_gain_V, c.agc_max_gain_V);
        const double a = 1.0 - std::exp(-ctx.period_s / c.agc_time_constant_s);
        gainCmd_V_ += a * (vTarget - gainCmd_V_);
    } else if (c.agc == AgcMode::Abc) {
        // ABC: the screen current is sensed directly (no video lag beyond the field in
        // which it is measured); above the limit the gain is cut in proportion, below it
        // recovers toward the manual setting, both with the ABC time constant.
        const double screen_A = ctx.mcpOut_e * kElectronCharge_C / ctx.period_s;
        double vTarget = c.gain_V;
        if (screen_A > c.abc_screen_limit_A) {
            const double gNow = c.mcpGain(ctx.gain_V);
            vTarget =
                std::min(c.gain_V, c.controlVoltageForGain(gNow * c.abc_screen_limit_A / screen_A));
        }
        vTarget = std::clamp(vTarget, c.agc_min_gain_V, c.agc_max_gain_V);
        const double a = 1.0 - std::exp(-ctx.period_s / c.abc_time_constant_s);
        gainCmd_V_ += a * (vTarget - gainCmd_V_);
        lag = 1;
    } else if (c.agc == AgcMode::Autogate) {
        // Auto-gating: the gain stays at the manual setting and the gate duty cycle carries
        // the loop (log-domain first-order lag), between the shortest gate and the field.
        const double minScale = std::min(c.gate_min_s / ctx.period_s, 1.0);
        const double target = std::clamp(gateCmd_ * want / signal, minScale, 1.0);
        const double a = 1.0 - std::exp(-ctx.period_s / c.agc_time_constant_s);
        gateCmd_ = std::exp(std::log(gateCmd_) + a * (std::log(target) - std::log(gateCmd_)));
    }
    const std::uint64_t k = ctx.field + static_cast<std::uint64_t>(lag);
    // Fields between now and k keep what was already commanded for them.
    gainRing_[k % kRing] = gainCmd_V_;
    gateRing_[k % kRing] = gateCmd_;
}

// ---- The chain ------------------------------------------------------------------------------

namespace {

// The preset with its automatic loop switched on: what the camera's AGC switch selects.
CameraParams withAutomaticLoop(const CameraParams& cam) {
    CameraParams c = cam;
    if (c.agc == AgcMode::Off) c.agc = AgcMode::Agc;
    return c;
}

}  // namespace

IiccdChain::IiccdChain(const CameraParams& cam, std::uint64_t seed,
                       const std::filesystem::path& configDir, GammaTableCache& gammaTables,
                       ChainOptions opt, ControlSource controls)
    : cam_(cam),
      camAuto_(withAutomaticLoop(cam)),
      source_(controls),
      optics_(cam_),
      gate_(cam_),
      cathode_(cam_, seed),
      halo_(cam_),
      bsp_(cam_),
      mcp_(cam_, seed, gammaTables),
      mcpSat_(cam_),
      phosphor_(cam_),
      blur_(cam_, opt, configDir),
      ccd_(cam_, seed),
      videoStage_(cam_),
      agc_(cam_),
      agcAuto_(camAuto_),
      rate_(cam_.width, cam_.height),
      sig_(cam_.width, cam_.height),
      counts_(cam_.width, cam_.height),
      video_(cam_.width, cam_.height),
      rowRate_(new float[kChainSlots * paddedRow(cam_.width)]),
      rowSig_(new float[kChainSlots * paddedRow(cam_.width)]),
      rowOptics_(static_cast<std::size_t>(cam_.height), 0.0),
      rowMcp_(static_cast<std::size_t>(cam_.height), 0.0),
      rowBad_(static_cast<std::size_t>(cam_.height), 0),
      rowLevel_(static_cast<std::size_t>(cam_.height), 0) {
    counts_.fill(static_cast<float>(std::clamp(cam_.video_offset_dc, 0.0, 65535.0)));
    // The phosphor's input is MCP saturation's output, at most a channel's full charge: its
    // afterglow store is bounded and kept in binary16 (PhosphorStage::boundInput).
    if (cam_.mcp_enabled && cam_.mcpsat_enabled) phosphor_.boundInput(cam_.mcpsat_pixel_charge_e);
}

IiccdChain::~IiccdChain() = default;

std::int64_t IiccdChain::countBadPixels(ImageView<const float> img) {
    std::int64_t bad = 0;
    for (int y = 0; y < img.height(); ++y) {
        const float* r = img.row(y);
        for (int x = 0; x < img.width(); ++x)
            bad += (r[x] >= 0.0f && r[x] < 3.0e38f) ? 0 : 1;
    }
    return bad;
}

IiccdChain::Controls IiccdChain::controlsFor(const CameraCommand& cmd, double period_s) noexcept {
    Controls c;
    bool autogate = false;
    if (source_ == ControlSource::Preset) {
        // The preset alone: manual gain for off / bsp / autogate, else its loop's command.
        const AgcMode m = cam_.agc;
        c.gain_V = m == AgcMode::Off || m == AgcMode::Bsp || m == AgcMode::Autogate
                       ? cam_.gain_V
                       : agc_.gain_V(field_);
        autogate = m == AgcMode::Autogate;
        c.loop = &agc_;
    } else {
        const AgcMode m = camAuto_.agc;
        const bool gainLoop = cmd.agc && (m == AgcMode::Agc || m == AgcMode::Abc);
        autogate = m == AgcMode::Autogate && (cmd.agc || cmd.gateMode == 2);
        if (gainLoop) {
            // Switched on now (or at the first field): the loop starts from the gain in
            // effect — the last field's, or at the first field the commanded one.
            if (!autoRunning_) {
                agcAuto_.start(field_ == 0 ? std::clamp(cmd.gain_V, camAuto_.agc_min_gain_V,
                                                        camAuto_.agc_max_gain_V)
                                           : lastGain_V_);
            }
            c.gain_V = agcAuto_.gain_V(field_);
        } else if (cmd.agc) {
            c.gain_V = cam_.gain_V;  // bsp / autogate: the tube gain stays at the preset's
        } else {
            c.gain_V = std::clamp(cmd.gain_V, 0.0, cam_.agc_max_gain_V);
        }
        if (gainLoop || autogate) c.loop = &agcAuto_;
        autoRunning_ = gainLoop;
        lastGain_V_ = c.gain_V;
    }
    // 2. gate
    if (autogate) {
        c.gate_s = gate_.gate_s(period_s, c.loop->gateScale(field_));
    } else if (source_ == ControlSource::Preset || cmd.gateMode == 1 || cmd.gateMode == 2) {
        c.gate_s = source_ == ControlSource::Command && cmd.gate_s > 0.0
                       ? std::clamp(cmd.gate_s, cam_.gate_min_s, period_s)
                       : gate_.gate_s(period_s, 1.0);
    } else {
        c.gate_s = period_s;  // continuous
    }
    return c;
}

const FieldInfo& IiccdChain::process(ImageView<const float> lpe) noexcept {
    const double t_s = (static_cast<double>(field_) + 0.5) * cam_.integrationPeriod_s();
    return process(lpe, CameraCommand{}, t_s);
}

const FieldInfo& IiccdChain::process(ImageView<const float> lpe, const CameraCommand& cmd,
                                     double t_sample_s) noexcept {
    info_ = FieldInfo{};
    info_.field = field_;
    if (lpe.width() != cam_.width || lpe.height() != cam_.height) {
        info_.size_mismatch = true;
        return info_;
    }
    FieldContext ctx;
    ctx.field = field_;
    ctx.period_s = cam_.integrationPeriod_s();
    const Controls controls = controlsFor(cmd, ctx.period_s);
    ctx.gain_V = controls.gain_V;
    ctx.gate_s = controls.gate_s;
    run(lpe, ctx);
    // 10. AGC loop: measures this field, commands field + lag.
    if (controls.loop != nullptr) controls.loop->update(ctx, info_.level_dc);
    info_.t_sample_s = t_sample_s;
    ++field_;
    return info_;
}

void IiccdChain::setExecutor(RowExecutor* exec) noexcept {
    exec_ = exec != nullptr ? exec : &serial_;
}

void IiccdChain::run(ImageView<const float> lpe, FieldContext& ctx) noexcept {
    const int w = cam_.width;
    const int h = cam_.height;
    // Each row's sums go to rowOptics_/rowMcp_ and are added up in row order afterwards: the
    // same sums, in the same order, however the bands ran.
    // 1. optics: the whole image first only where the gain depends on it (BSP: the cathode
    // current) or the halo spreads it; otherwise row by row below.
    const bool opticsFirst = bsp_.enabled() || halo_.enabled();
    const bool halo = halo_.enabled();
    if (opticsFirst) {
        // With the halo, bands of whole cell rows: each band's rows, then its cells' sums.
        const int units = halo ? halo_.cellRows() : h;
        const int rowsPer = halo ? HaloStage::kBlock : 1;
        auto optics = [&](int b) {
            const int u0 = bandStart(b, units), u1 = bandStart(b + 1, units);
            for (int y = u0 * rowsPer; y < std::min(h, u1 * rowsPer); ++y)
                rowBad_[y] = optics_.applyRow(lpe.row(y), rate_.row(y), y, rowOptics_[y]);
            if (halo) halo_.sumCells(rate_.cview(), u0, u1);
        };
        forEachIndex(*exec_, kChainSlots, optics);
        addOpticsSums(ctx);
        // 3b: a share of the photoelectrons lands on the halo disk (added to each row below).
        if (halo) halo_.spread(*exec_);
        cathode_.begin(ctx, w, h);
    }
    // 4. bright-source protection (the gain for this field), 5. MCP gain
    const auto cathodeCurrent_A = [&] {
        return ctx.cathodeRate_pe_s * ctx.gate_s / ctx.period_s * kElectronCharge_C;
    };
    const double bspFactor = opticsFirst ? bsp_.factor(cathodeCurrent_A()) : 1.0;
    ctx.mcpGain = cam_.mcpGain(ctx.gain_V) * bspFactor;
    FieldContext rowCtx = ctx;  // photocathode constants for the row-by-row case
    if (!opticsFirst) cathode_.begin(rowCtx, w, h);
    mcp_.begin(ctx);
    mcpSat_.begin(ctx);
    phosphor_.begin(ctx);
    // 1, 3, 5, 6 row by row: optics → photocathode → MCP → phosphor, written straight into
    // the blur's FFT input (or the signal image when the MTF is off); each band of rows with
    // its own scratch.
    auto rows = [&](int b) {
        const std::size_t off = static_cast<std::size_t>(b) * paddedRow(w);
        float* rate = rowRate_.get() + off;
        float* sig = rowSig_.get() + off;
        for (int y = bandStart(b, h); y < bandStart(b + 1, h); ++y) {
            const float* r = rate_.row(y);
            if (halo) {
                // Into the band's row: the image row is only read (no write-back stream).
                halo_.addBackRow(r, rate, y);
                r = rate;
            }
            if (!opticsFirst) {
                rowBad_[y] = optics_.applyRow(lpe.row(y), rate, y, rowOptics_[y]);
                r = rate;
            }
            cathode_.applyRow(r, sig, w, y, b);
            if (mcp_.enabled()) {
                // With saturation the row's output is saturation's sum, not the MCP's.
                const double rowOut = mcp_.applyRow(sig, w, y, b, !mcpSat_.enabled());
                rowMcp_[y] = mcpSat_.enabled() ? mcpSat_.applyRow(sig, w, y) : rowOut;
            }
            float* dst = blur_.enabled() ? blur_.slotRow(b) : sig_.row(y);
            if (phosphor_.enabled())
                phosphor_.applyRow(sig, dst, w, y);
            else
                std::copy(sig, sig + w, dst);
            if (blur_.enabled()) blur_.forwardRow(dst, y);  // 7's row transform, the row in cache
        }
    };
    forEachIndex(*exec_, kChainSlots, rows);
    double mcpTotal = 0.0;
    for (int y = 0; y < h; ++y)
        mcpTotal += rowMcp_[y];
    if (!opticsFirst) {
        addOpticsSums(ctx);
        cathode_.begin(ctx, w, h);  // the EBI, added after the optics as apply() does
    }
    ctx.mcpOut_e = mcp_.enabled() ? mcpTotal : ctx.cathodeRate_pe_s * ctx.gate_s;
    info_.gain_V = ctx.gain_V;
    info_.mcp_gain = ctx.mcpGain;
    info_.gate_s = ctx.gate_s;
    info_.bsp_factor = bspFactor;
    info_.cathode_current_A = cathodeCurrent_A();
    info_.screen_current_A = ctx.mcpOut_e * kElectronCharge_C / ctx.period_s;
    info_.mean_pe = ctx.cathodeRate_pe_s * ctx.gate_s / (w * h);
    readOut(ctx);
}

void IiccdChain::addOpticsSums(FieldContext& ctx) noexcept {
    std::int64_t bad = 0;
    double total = 0.0;
    for (int y = 0; y < cam_.height; ++y) {
        bad += rowBad_[y];
        total += rowOptics_[y];
    }
    info_.bad_input_px = bad;
    ctx.cathodeRate_pe_s += total;
}

void IiccdChain::readOut(const FieldContext& ctx) noexcept {
    const int w = cam_.width;
    const int h = cam_.height;
    // 7. blur: its row transforms were made with the rows (run()); the columns now, the
    // inverse row transforms with the CCD load below.
    blur_.filterColumns(*exec_);
    // 8. CCD, 9. video: load (PRNU, dark) from the blurred image by bands of rows (each band
    // its own column maxima), then the column sums and blooming's down sweep where needed,
    // bloom, then smear and read noise by bands of rows, each row read out converted at once.
    ccd_.begin(ctx);
    if (blur_.enabled()) {
        ccd_.beginLoad();
        auto load = [&](int b) {
            float* row = blur_.slotRow(b);
            for (int y = bandStart(b, h); y < bandStart(b + 1, h); ++y) {
                blur_.inverseRow(y, row);
                ccd_.loadRowMax(row, sig_.row(y), y, b);
            }
        };
        forEachIndex(*exec_, kChainSlots, load);
        ccd_.finishLoad(sig_.view());
    } else {
        for (int y = 0; y < h; ++y)
            ccd_.loadRow(sig_.row(y), sig_.row(y), y);
    }
    info_.saturated_px = ccd_.bloom(sig_.view());
    auto finish = [&](int b) {
        for (int y = bandStart(b, h); y < bandStart(b + 1, h); ++y) {
            float* v = sig_.row(y);
            ccd_.finishRow(v, y, b);
            rowLevel_[y] = videoStage_.readsRow(field_, y)
                               ? videoStage_.applyRow(v, counts_.row(y), video_.row(y), w)
                               : -1;
        }
    };
    forEachIndex(*exec_, kChainSlots, finish);
    double sum = 0.0;
    std::int64_t n = 0;
    for (int y = 0; y < h; ++y) {
        if (rowLevel_[y] < 0) continue;
        sum += static_cast<double>(rowLevel_[y]);
        n += w;
    }
    info_.level_dc = n > 0 ? sum / static_cast<double>(n) : 0.0;
}

}  // namespace nvs::sensor
