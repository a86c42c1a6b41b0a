#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
#define NVS_PHOSPHOR_AVX512 1
#endif

#include <algorithm>
#include <bit>
#include <cmath>
#include <cstring>

#include "sim/core/cpu_isa.h"
#include "sim/core/simd.h"
#include "sim/core/units.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/half.h"
#include "sim/sensor/preset_reader.h"
#include "sim/sensor/stages/phosphor.h"

namespace nvs::sensor {

void PhosphorParams::read(const PresetReader& root) {
    const PresetReader ph = root.sub("phosphor");
    phosphor_enabled = ph.get<bool>("enabled", phosphor_enabled);
    phosphor_type = ph.get<std::string>("type", phosphor_type);
    phosphor_decay_s = ph.get<std::vector<double>>("decay_s", phosphor_decay_s);
    phosphor_weight = ph.get<std::vector<double>>("weight", phosphor_weight);
    require(phosphor_decay_s.size() == phosphor_weight.size() && !phosphor_decay_s.empty() &&
                phosphor_decay_s.size() <= 4,
            ph, "weight", "decay_s and weight need the same length, 1..4");
    double wsum = 0.0;
    for (std::size_t i = 0; i < phosphor_weight.size(); ++i) {
        require(phosphor_decay_s[i] > 0.0, ph, "decay_s", "time constants must be > 0");
        require(phosphor_weight[i] >= 0.0, ph, "weight", "weights must be >= 0");
        wsum += phosphor_weight[i];
    }
    require(std::fabs(wsum - 1.0) < 1e-6, ph, "weight", "weights must sum to 1");
    screen_voltage_V = positive(ph, "screen_voltage_V", screen_voltage_V);
    screen_dead_voltage_V = nonNegative(ph, "dead_voltage_V", screen_dead_voltage_V);
    require(screen_dead_voltage_V < screen_voltage_V, ph, "dead_voltage_V",
            "must be below screen_voltage_V");
    phosphor_photons_per_eV = positive(ph, "photons_per_eV", phosphor_photons_per_eV);
    phosphor_peak_nm = positive(ph, "peak_nm", phosphor_peak_nm);
    phosphor_efficacy_lm_W = positive(ph, "efficacy_lm_W", phosphor_efficacy_lm_W);
    taper_transmission = positive(ph, "taper_transmission", taper_transmission);
    ccd_window_transmission = positive(ph, "ccd_window_transmission", ccd_window_transmission);
    ccd_qe = positive(ph, "ccd_qe", ccd_qe);
    ccd_fill_factor = positive(ph, "ccd_fill_factor", ccd_fill_factor);
}

double PhosphorParams::screenLumensPerBeamWatt() const {
    // P photons per eV of beam, each of energy hc/λ: the radiant efficiency P·hc/(λ·e).
    const double photon_J = kPlanck_J_s * kSpeedOfLight_m_s / (phosphor_peak_nm * 1e-9);
    return phosphor_photons_per_eV * photon_J / kElectronCharge_C * phosphor_efficacy_lm_W;
}

double PhosphorParams::ccdElectronsPerMcpElectron() const {
    if (!phosphor_enabled) return 1.0;
    // Eq. 6.2/6.3: N_CCD = (Vs − Vd)·P·T_fot·T_CCD·QE_CCD per electron striking the screen;
    // the CCD cell's fill factor takes its share of the light falling on it.
    return (screen_voltage_V - screen_dead_voltage_V) * phosphor_photons_per_eV *
           taper_transmission * ccd_window_transmission * ccd_qe * ccd_fill_factor;
}

namespace {

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

#define NVS_PHOSPHOR_ROW(M)                                                            \
    NVS_SIMD_CLONES void phosphorRow##M(const float* in, float* out, float* st, int w, \
                                        float nowEta, const float* k, const float* dc, \
                                        const float* em) noexcept {                    \
        phosphorRowBody<M>(in, out, st, w, nowEta, k, dc, em);                         \
    }
NVS_PHOSPHOR_ROW(0)
NVS_PHOSPHOR_ROW(1)
NVS_PHOSPHOR_ROW(2)
NVS_PHOSPHOR_ROW(3)
NVS_PHOSPHOR_ROW(4)
#undef NVS_PHOSPHOR_ROW

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
    return hostHasAvx512();
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

}  // namespace nvs::sensor
