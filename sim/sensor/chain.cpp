#include "sim/sensor/chain.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>

#include "sim/core/rng.h"
#include "sim/core/units.h"
#include "sim/sensor/mtf.h"

namespace nvs::sensor {

namespace {

constexpr double kElectronCharge_C = 1.602176634e-19;

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
// Philox blocks that cover `n` words.
inline int blocksFor(int n) {
    return (n + 3) / 4;
}

}  // namespace

// ---- 1. Optics ------------------------------------------------------------------------------

OpticsStage::OpticsStage(const CameraParams& c) : factor_(c.width, c.height) {
    const double onAxis = c.peRatePerLpe_on_axis();
    const double px_m = c.pitch_x_um * 1e-6 * c.taper_magnification;
    const double py_m = c.pitch_y_um * 1e-6 * c.taper_magnification;
    const double f_m = c.focal_length_mm * 1e-3;
    const double cx = 0.5 * (c.width - 1);
    const double cy = 0.5 * (c.height - 1);
    for (int y = 0; y < c.height; ++y) {
        float* r = factor_.row(y);
        for (int x = 0; x < c.width; ++x) {
            double k = onAxis;
            if (c.cos4) {
                // cos⁴θ off axis: cos θ = f / sqrt(f² + r²), r the distance on the cathode.
                const double dx = (x - cx) * px_m;
                const double dy = (y - cy) * py_m;
                const double c2 = f_m * f_m / (f_m * f_m + dx * dx + dy * dy);
                k *= c2 * c2;
            }
            r[x] = static_cast<float>(k);
        }
    }
}

std::int64_t OpticsStage::apply(ImageView<const float> lpe, ImageView<float> rate,
                                FieldContext& ctx) const noexcept {
    std::int64_t bad = 0;
    double total = 0.0;
    for (int y = 0; y < lpe.height(); ++y) {
        const float* in = lpe.row(y);
        const float* k = factor_.row(y);
        float* out = rate.row(y);
        float rowSum = 0.0f;
        int rowBad = 0;
        for (int x = 0; x < lpe.width(); ++x) {
            const float v = in[x];
            // NaN fails both comparisons; +inf fails the second. Branch-free (vector loop).
            const bool ok = (v >= 0.0f) & (v < 3.0e38f);
            rowBad += static_cast<int>(!ok);
            out[x] = (ok ? v : 0.0f) * k[x];
            rowSum += out[x];
        }
        bad += rowBad;
        total += static_cast<double>(rowSum);
    }
    ctx.cathodeRate_pe_s += total;
    return bad;
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
      mean_(new float[paddedRow(c.width)]),
      words_(new std::uint32_t[paddedRow(c.width)]) {}

void PhotocathodeStage::apply(ImageView<const float> rate, ImageView<float> pe,
                              FieldContext& ctx) noexcept {
    const float t = static_cast<float>(ctx.gate_s);
    const float ebi = static_cast<float>(ebi_pe_s_);
    const int w = rate.width();
    ctx.cathodeRate_pe_s += ebi_pe_s_ * w * rate.height();
    const PixelRng rng(seed_, RngStream::Photocathode, ctx.field);
    float* __restrict mean = mean_.get();
    for (int y = 0; y < rate.height(); ++y) {
        const float* __restrict r = rate.row(y);
        float* __restrict out = pe.row(y);
        if (!noise_) {
            for (int x = 0; x < w; ++x)
                out[x] = (r[x] + ebi) * t;
            continue;
        }
        // One word per pixel; Poisson by the exact row sampler (zeros settled in a vector
        // pass, the rest by inversion or PTRS).
        for (int x = 0; x < w; ++x)
            mean[x] = (r[x] + ebi) * t;
        rng.rowWords(static_cast<std::uint32_t>(y), 0, 0, blocksFor(w), words_.get());
        poissonRow(mean, words_.get(), out, w, rng, 0, static_cast<std::uint32_t>(y));
    }
}

// ---- 4. BSP ---------------------------------------------------------------------------------

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

McpStage::McpStage(const CameraParams& c, std::uint64_t seed)
    : enabled_(c.mcp_enabled),
      noise_(c.mcp_noise && c.mcp_noise_factor > 1.0 + 1e-9),
      k_(c.mcp_noise_factor > 1.0 + 1e-9 ? 1.0 / (c.mcp_noise_factor - 1.0) : 0.0),
      seed_(seed),
      words_(new std::uint32_t[2 * paddedRow(c.width)]),
      z_(new float[2 * paddedRow(c.width)]) {}

void McpStage::apply(ImageView<float> pe, FieldContext& ctx) noexcept {
    const double g = ctx.mcpGain;
    const int w = pe.width();
    double total = 0.0;
    const PixelRng rng(seed_, RngStream::McpGain, ctx.field);
    std::uint32_t* wz = words_.get();
    // Marsaglia–Tsang constants for the last shape seen (runs of equal counts are common).
    double lastShape = -1.0, d = 0.0, c = 0.0;
    const double theta = k_ > 0.0 ? g / k_ : 0.0;
    for (int y = 0; y < pe.height(); ++y) {
        float* __restrict v = pe.row(y);
        if (!noise_) {
            const float gf = static_cast<float>(g);
            float rowSum = 0.0f;
            for (int x = 0; x < w; ++x) {
                v[x] *= gf;
                rowSum += v[x];
            }
            total += static_cast<double>(rowSum);
            continue;
        }
        // The gain of one electron has mean G and variance (F − 1)G²: a Gamma(k, G/k) with
        // k = 1/(F − 1). N independent ones sum to Gamma(N·k, G/k) exactly. Pixels with
        // N = 0 draw nothing; pixel x takes words 2x (normal) and 2x + 1 (uniform) of its row
        // for the first Marsaglia–Tsang attempt, its pixel stream for any further one. The
        // words of pixel x are block x/2 of the row: made for the whole row when many pixels
        // need them, one block per pixel when few do; the same words either way.
        int active = 0;
        for (int x = 0; x < w; ++x)
            active += v[x] > 0.0f ? 1 : 0;
        if (active == 0) continue;
        const std::uint32_t yy = static_cast<std::uint32_t>(y);
        const bool wholeRow = active * 8 > w;
        if (wholeRow) {
            rng.rowWords(yy, 0, 0, blocksFor(2 * w), wz);
            normalsFromWords(wz, z_.get(), 2 * w);  // even entries used
        }
        double rowSum = 0.0;
        for (int x = 0; x < w; ++x) {
            const double n = static_cast<double>(v[x]);
            if (!(n > 0.0)) continue;
            std::uint32_t block[4];
            const std::uint32_t* wx = nullptr;
            if (wholeRow) {
                wx = wz + 2 * x;
            } else {
                rng.block(yy, 0, static_cast<std::uint32_t>(x / 2), block);
                wx = block + 2 * (x % 2);
            }
            const double shape = n * k_;
            double e = 0.0;
            if (shape >= 1.0) {
                if (shape != lastShape) {
                    lastShape = shape;
                    d = shape - 1.0 / 3.0;
                    c = 1.0 / std::sqrt(9.0 * d);
                }
                // First attempt inline (accepted by the squeeze ~95 % of the time).
                const double z = static_cast<double>(wholeRow ? z_[2 * x] : normalFromWord(wx[0]));
                const double u = uniformFromWord(wx[1]);
                double t = 1.0 + c * z;
                t = t * t * t;
                if (t > 0.0 && u < 1.0 - 0.0331 * (z * z) * (z * z)) {
                    e = theta * d * t;
                }
            }
            if (e == 0.0) {
                PixelStream more = rng.pixelStream(static_cast<std::uint32_t>(x), yy);
                e = gammaFromWords(shape, theta, wx[0], wx[1], more);
            }
            v[x] = static_cast<float>(e);
            rowSum += e;
        }
        total += rowSum;
    }
    ctx.mcpOut_e = total;
}

// ---- 6. Phosphor ----------------------------------------------------------------------------

double PhosphorStage::inPeriodFraction(double tau_s, double gate_s, double period_s) {
    // An impulse at t0 is emitted as exp(−(t − t0)/τ)/τ; by the period's end T it has given
    // 1 − exp(−(T − t0)/τ). Averaged over t0 uniform in [0, g]:
    //   f = 1 − exp(−T/τ)·(exp(g/τ) − 1)/(g/τ).
    const double x = gate_s / tau_s;
    const double ratio = x < 1e-12 ? 1.0 : std::expm1(x) / x;
    const double tail = std::exp(-period_s / tau_s) * ratio;
    return std::clamp(1.0 - tail, 0.0, 1.0);
}

PhosphorStage::PhosphorStage(const CameraParams& c)
    : enabled_(c.phosphor_enabled), eta_(c.ccdElectronsPerMcpElectron()) {
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
        if (stored_[i]) state_[i] = ImageF(c.width, c.height);
    }
}

void PhosphorStage::reset() noexcept {
    for (int i = 0; i < n_; ++i)
        if (stored_[i]) state_[i].fill(0.0f);
}

void PhosphorStage::apply(ImageView<float> s, const FieldContext& ctx) noexcept {
    if (!enabled_) return;
    float now = 0.0f;  // fraction of this period's excitation seen in this period
    float keep[4] = {};
    float decay[4] = {};
    float emit[4] = {};
    int m = 0;
    int idx[4] = {};
    for (int i = 0; i < n_; ++i) {
        const double f = inPeriodFraction(tau_s_[i], ctx.gate_s, ctx.period_s);
        if (!stored_[i]) {
            now += static_cast<float>(weight_[i]);  // emitted at once, to within 1e-7
            continue;
        }
        now += static_cast<float>(weight_[i] * f);
        const double d = std::exp(-ctx.period_s / tau_s_[i]);
        idx[m] = i;
        keep[m] = static_cast<float>(weight_[i] * (1.0 - f));
        decay[m] = static_cast<float>(d);
        emit[m] = static_cast<float>(1.0 - d);
        ++m;
    }
    switch (m) {
        case 0:
            applyRows<0>(s, now, keep, decay, emit, idx);
            break;
        case 1:
            applyRows<1>(s, now, keep, decay, emit, idx);
            break;
        case 2:
            applyRows<2>(s, now, keep, decay, emit, idx);
            break;
        case 3:
            applyRows<3>(s, now, keep, decay, emit, idx);
            break;
        default:
            applyRows<4>(s, now, keep, decay, emit, idx);
            break;
    }
}

// The number of stored components is a template parameter so that the per-pixel loop has a
// fixed shape and vectorises.
template <int M>
void PhosphorStage::applyRows(ImageView<float> s, float now, const float* keep, const float* decay,
                              const float* emit, const int* idx) noexcept {
    const float eta = static_cast<float>(eta_);
    float k[M > 0 ? M : 1], dc[M > 0 ? M : 1], em[M > 0 ? M : 1];
    for (int j = 0; j < M; ++j) {
        k[j] = keep[j] * eta;
        dc[j] = decay[j];
        em[j] = emit[j];
    }
    const float nowEta = now * eta;
    const int w = s.width();
    for (int y = 0; y < s.height(); ++y) {
        float* __restrict v = s.row(y);
        float* __restrict st[M > 0 ? M : 1];
        for (int j = 0; j < M; ++j)
            st[j] = state_[idx[j]].row(y);
        for (int x = 0; x < w; ++x) {
            const float e = v[x];
            float out = e * nowEta;
            if constexpr (M > 0) {
                const float s0 = st[0][x];
                out += s0 * em[0];
                st[0][x] = s0 * dc[0] + e * k[0];
            }
            if constexpr (M > 1) {
                const float s1 = st[1][x];
                out += s1 * em[1];
                st[1][x] = s1 * dc[1] + e * k[1];
            }
            if constexpr (M > 2) {
                const float s2 = st[2][x];
                out += s2 * em[2];
                st[2][x] = s2 * dc[2] + e * k[2];
            }
            if constexpr (M > 3) {
                const float s3 = st[3][x];
                out += s3 * em[3];
                st[3][x] = s3 * dc[3] + e * k[3];
            }
            v[x] = out;
        }
    }
}

// ---- 7. Blur --------------------------------------------------------------------------------

struct BlurStage::Fft {
    float* real = nullptr;
    fftwf_complex* spec = nullptr;
    float* filter = nullptr;
    fftwf_plan fwd = nullptr;
    fftwf_plan inv = nullptr;
    ~Fft() {
        if (fwd) fftwf_destroy_plan(fwd);
        if (inv) fftwf_destroy_plan(inv);
        fftwf_free(real);
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

BlurStage::BlurStage(const CameraParams& c, const ChainOptions& opt)
    : enabled_(c.mtf_enabled), w_(c.width), h_(c.height) {
    if (!enabled_) return;
    // A margin of at least 8 px mirrored on each side keeps the periodic FFT from wrapping
    // the opposite edge into the image (for 768 × 494: 16 px left/right, 9 px top/bottom).
    wp_ = fastSize(w_);
    hp_ = fastSize(h_);
    fft_ = std::make_unique<Fft>();
    const int wc = wp_ / 2 + 1;
    const std::size_t nr = static_cast<std::size_t>(wp_) * static_cast<std::size_t>(hp_);
    const std::size_t nc = static_cast<std::size_t>(wc) * static_cast<std::size_t>(hp_);
    fft_->real = fftwf_alloc_real(nr);
    fft_->spec = fftwf_alloc_complex(nc);
    fft_->filter = fftwf_alloc_real(nc);
    if (!fft_->real || !fft_->spec || !fft_->filter) throw SetupError("blur: out of memory");
    const unsigned flags = opt.measureFft ? FFTW_MEASURE : FFTW_ESTIMATE;
    fft_->fwd = fftwf_plan_dft_r2c_2d(hp_, wp_, fft_->real, fft_->spec, flags);
    fft_->inv = fftwf_plan_dft_c2r_2d(hp_, wp_, fft_->spec, fft_->real, flags);
    if (!fft_->fwd || !fft_->inv) throw SetupError("blur: FFTW could not plan");
    // The filter: the product of the stage MTFs at each DFT frequency, converted from cycles
    // per pixel to cycles per mm at the cathode; 1/(wp·hp) normalises FFTW's round trip.
    const double px = cathodePitchX_mm(c);
    const double py = cathodePitchY_mm(c);
    const double norm = 1.0 / static_cast<double>(nr);
    for (int ky = 0; ky < hp_; ++ky) {
        const double fy = (ky <= hp_ / 2 ? ky : ky - hp_) / static_cast<double>(hp_) / py;
        for (int kx = 0; kx < wc; ++kx) {
            const double fx = kx / static_cast<double>(wp_) / px;
            fft_->filter[static_cast<std::size_t>(ky) * wc + kx] =
                static_cast<float>(systemMtf(c, fx, fy) * norm);
        }
    }
}

BlurStage::~BlurStage() = default;

void BlurStage::apply(ImageView<float> img) noexcept {
    if (!enabled_) return;
    float* r = fft_->real;
    for (int y = 0; y < hp_; ++y) {
        const float* src = img.row(padIndex(y, h_, hp_));
        float* dst = r + static_cast<std::ptrdiff_t>(y) * wp_;
        std::copy(src, src + w_, dst);
        for (int x = w_; x < wp_; ++x)
            dst[x] = src[padIndex(x, w_, wp_)];
    }
    fftwf_execute(fft_->fwd);
    const int wc = wp_ / 2 + 1;
    const std::size_t nc = static_cast<std::size_t>(wc) * static_cast<std::size_t>(hp_);
    fftwf_complex* s = fft_->spec;
    const float* f = fft_->filter;
    for (std::size_t i = 0; i < nc; ++i) {
        s[i][0] *= f[i];
        s[i][1] *= f[i];
    }
    fftwf_execute(fft_->inv);
    for (int y = 0; y < h_; ++y) {
        const float* src = r + static_cast<std::ptrdiff_t>(y) * wp_;
        float* dst = img.row(y);
        for (int x = 0; x < w_; ++x)
            dst[x] = std::max(src[x], 0.0f);  // ringing below zero is not charge
    }
}

// ---- 8. CCD ---------------------------------------------------------------------------------

CcdStage::CcdStage(const CameraParams& c, std::uint64_t seed)
    : cam_(&c),
      seed_(seed),
      line_(new float[static_cast<std::size_t>(2 * std::max(c.width, c.height) + 2)]),
      colSum_(new float[paddedRow(c.width)]),
      colMax_(new float[paddedRow(c.width)]),
      words_(new std::uint32_t[paddedRow(c.width)]),
      z_(new float[paddedRow(c.width)]) {
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

std::int64_t CcdStage::bloomColumns(ImageView<float> e, float fw, const float* cmax) noexcept {
    // bloomLine's sweeps for every column at once, row by row (cache-friendly, vector code),
    // over the span of columns that reach full well: down the columns each cell over full
    // well keeps fw, sends half its excess down (filling cells below to fw on the way) and
    // stores the other half; then up the columns the stored halves fill the cells above.
    // Columns below full well carry nothing and are unchanged, as in bloomLine.
    const int w = e.width();
    const int h = e.height();
    int x0 = 0, x1 = w;
    while (x0 < w && cmax[x0] < fw)
        ++x0;
    while (x1 > x0 && cmax[x1 - 1] < fw)
        --x1;
    if (x0 >= x1) return 0;
    const int n = x1 - x0;
    // Value selects (not std::min/max, which return references) keep the loops branch-free.
    const auto lo = [](float p, float q) { return p < q ? p : q; };
    const auto hi = [](float p, float q) { return p > q ? p : q; };
    float* __restrict moving = line_.get();
    std::fill(moving, moving + n, 0.0f);
    for (int y = 0; y < h; ++y) {
        float* __restrict v = e.row(y) + x0;
        float* __restrict up = upCarry_.row(y) + x0;
        for (int i = 0; i < n; ++i) {
            // d = c − fw: excess max(d, 0) = (d + |d|)/2 and room max(−d, 0) = (|d| − d)/2,
            // both exact in floating point; min(c, fw) = c − excess.
            const float c = v[i];
            const float m = moving[i];
            const float d = c - fw;
            const float ad = std::fabs(d);
            const float excess = 0.5f * (d + ad);
            const float take = lo(0.5f * (ad - d), m);
            v[i] = (c - excess) + take;
            moving[i] = m + (0.5f * excess - take);
            up[i] = 0.5f * excess;
        }
    }
    std::fill(moving, moving + n, 0.0f);
    std::int64_t sat = 0;
    for (int y = h - 1; y >= 0; --y) {
        float* __restrict v = e.row(y) + x0;
        const float* __restrict up = upCarry_.row(y) + x0;
        int rowSat = 0;
        for (int i = 0; i < n; ++i) {
            const float take = lo(hi(fw - v[i], 0.0f), moving[i]);
            v[i] += take;
            moving[i] += up[i] - take;
            rowSat += static_cast<int>(v[i] >= fw);
        }
        sat += rowSat;
    }
    return sat;
}

std::int64_t CcdStage::apply(ImageView<float> e, const FieldContext& ctx) noexcept {
    const CameraParams& c = *cam_;
    const int w = e.width();
    const int h = e.height();
    const float dark = static_cast<float>(c.dark_e_s * ctx.period_s);
    const bool fullWell = c.full_well_e > 0.0;
    const float fw = static_cast<float>(c.full_well_e);
    // Pass 1: fixed pattern and dark charge, and the largest charge of each column (which
    // columns need the blooming sweep).
    float* __restrict cmax = colMax_.get();
    std::fill(cmax, cmax + w, 0.0f);
    const bool prnu = !prnu_.empty();
    for (int y = 0; y < h; ++y) {
        float* __restrict v = e.row(y);
        if (prnu) {
            const float* __restrict p = prnu_.row(y);
            for (int x = 0; x < w; ++x)
                v[x] = v[x] * p[x] + dark;
        } else if (dark > 0.0f) {
            for (int x = 0; x < w; ++x)
                v[x] += dark;
        }
        if (fullWell) {
            for (int x = 0; x < w; ++x)
                cmax[x] = std::max(cmax[x], v[x]);
        }
    }
    std::int64_t saturated = 0;
    if (fullWell) {
        float* carry = line_.get();
        if (c.bloom == BloomDirection::Vertical) {
            saturated += bloomColumns(e, fw, cmax);
        } else {
            bool any = false;
            for (int x = 0; x < w; ++x)
                any = any || cmax[x] >= fw;
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
        }
    }
    // Interline smear: light leaking into the vertical register while the column is clocked
    // out adds a fraction of the column's mean charge to every cell of it.
    const bool smear = c.smear_rel > 0.0;
    float* __restrict cs = colSum_.get();
    if (smear) {
        std::fill(cs, cs + w, 0.0f);
        for (int y = 0; y < h; ++y) {
            const float* __restrict v = e.row(y);
            for (int x = 0; x < w; ++x)
                cs[x] += v[x];
        }
        const float k = static_cast<float>(c.smear_rel / h);
        for (int x = 0; x < w; ++x)
            cs[x] *= k;
    }
    // Read noise, the dark charge's shot noise, and the video pre-amplifier noise referred
    // back to electrons, all additive and Gaussian, in one draw per cell (one word per cell,
    // inverse-CDF normals), in the same pass as the smear.
    const double darkVar = static_cast<double>(dark);
    const float sigma = static_cast<float>(std::sqrt(noiseSigma_e_ * noiseSigma_e_ + darkVar));
    if (!(sigma > 0.0f) && !smear) return saturated;
    const PixelRng rng(seed_, RngStream::ReadNoise, ctx.field);
    float* __restrict z = z_.get();
    if (!(sigma > 0.0f)) std::fill(z, z + w, 0.0f);
    // Read noise belongs to the rows read out: in field mode only this field's lines.
    const int readY0 = c.scan == ScanMode::Field ? static_cast<int>(ctx.field & 1u) : 0;
    const int readDy = c.scan == ScanMode::Field ? 2 : 1;
    for (int y = 0; y < h; ++y) {
        float* __restrict v = e.row(y);
        const bool read = y >= readY0 && (y - readY0) % readDy == 0;
        if (!read && !smear) continue;
        if (!read) {
            for (int x = 0; x < w; ++x)
                v[x] += cs[x];
            continue;
        }
        if (sigma > 0.0f) {
            rng.rowWords(static_cast<std::uint32_t>(y), 0, 0, blocksFor(w), words_.get());
            normalsFromWords(words_.get(), z, w);
        }
        if (smear) {
            for (int x = 0; x < w; ++x)
                v[x] += cs[x] + sigma * z[x];
        } else {
            for (int x = 0; x < w; ++x)
                v[x] += sigma * z[x];
        }
    }
    return saturated;
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
            lut_[static_cast<std::size_t>(i)] = static_cast<std::uint16_t>(j);
        }
        oneStep_ = most <= 1;
        if (oneStep_ || cells >= (1 << 22)) break;
        cells *= 2;
    }
    thr_.push_back(3.0e38f);  // sentinel
}

double VideoStage::apply(ImageView<const float> e, std::uint64_t field, ImageView<float> counts,
                         ImageView<std::uint16_t> video) const noexcept {
    const CameraParams& c = *cam_;
    const float gain = static_cast<float>(c.video_gain_dc_per_e);
    const float offset = static_cast<float>(c.video_offset_dc);
    const float maxc = static_cast<float>(maxCount_);
    const float bottom = std::clamp(std::nearbyint(offset), 0.0f, maxc);
    const int parity = static_cast<int>(field & 1u);
    const int y0 = c.scan == ScanMode::Field ? parity : 0;
    const int dy = c.scan == ScanMode::Field ? 2 : 1;
    const int w = e.width();
    const int cells = static_cast<int>(lut_.size()) - 1;
    double sum = 0.0;
    std::int64_t n = 0;
    for (int y = y0; y < e.height(); y += dy) {
        const float* __restrict s = e.row(y);
        float* __restrict o = counts.row(y);
        std::uint16_t* __restrict v = video.row(y);
        // Linear: round to nearest even by the 1.5·2²³ trick (exact for |x| < 2²²; the
        // value is clamped to [−1, max + 1] first), then clamp to the ADC range.
        for (int x = 0; x < w; ++x) {
            float dc = std::clamp(s[x] * gain + offset, -1.0f, maxc + 1.0f);
            dc = (dc + 0x1.8p23f) - 0x1.8p23f;
            o[x] = std::clamp(dc, 0.0f, maxc);
        }
        if (gamma_ && oneStep_) {
            const std::uint16_t* lut = lut_.data();
            const float* thr = thr_.data();
            const float top = static_cast<float>(cells);
            for (int x = 0; x < w; ++x) {
                const float sig = s[x] * gain;
                const float cellf = std::min(std::max(sig * lutScale_, 0.0f), top);
                const std::uint16_t j0 = lut[static_cast<int>(cellf)];
                const int j = j0 + static_cast<int>(thr[j0] <= sig);
                const float level = std::min(bottom + static_cast<float>(j), maxc);
                o[x] = sig > 0.0f ? level : o[x];
            }
        } else if (gamma_) {
            for (int x = 0; x < w; ++x) {
                const float sig = s[x] * gain;
                if (!(sig > 0.0f)) continue;
                const int cell = std::min(static_cast<int>(sig * lutScale_), cells);
                std::size_t j = lut_[static_cast<std::size_t>(cell)];
                while (thr_[j] <= sig)
                    ++j;
                o[x] = std::min(bottom + static_cast<float>(j), maxc);
            }
        }
        float rowSum = 0.0f;
        for (int x = 0; x < w; ++x) {
            v[x] = static_cast<std::uint16_t>(static_cast<std::int32_t>(o[x]));
            rowSum += o[x];
        }
        sum += static_cast<double>(rowSum);
        n += w;
    }
    return n > 0 ? sum / static_cast<double>(n) : 0.0;
}

// ---- 10. AGC loop ---------------------------------------------------------------------------

AgcLoop::AgcLoop(const CameraParams& c) : cam_(&c) {
    reset();
}

void AgcLoop::reset() noexcept {
    for (int i = 0; i < kRing; ++i) {
        gainRing_[i] = cam_->gain_V;
        gateRing_[i] = 1.0;
    }
    gainCmd_V_ = cam_->gain_V;
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

IiccdChain::IiccdChain(const CameraParams& cam, std::uint64_t seed, ChainOptions opt)
    : cam_(cam),
      optics_(cam_),
      gate_(cam_),
      cathode_(cam_, seed),
      bsp_(cam_),
      mcp_(cam_, seed),
      phosphor_(cam_),
      blur_(cam_, opt),
      ccd_(cam_, seed),
      videoStage_(cam_),
      agc_(cam_),
      rate_(cam_.width, cam_.height),
      sig_(cam_.width, cam_.height),
      counts_(cam_.width, cam_.height),
      video_(cam_.width, cam_.height) {
    counts_.fill(static_cast<float>(std::clamp(cam_.video_offset_dc, 0.0, 65535.0)));
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

const FieldInfo& IiccdChain::process(ImageView<const float> lpe) noexcept {
    info_ = FieldInfo{};
    info_.field = field_;
    if (lpe.width() != cam_.width || lpe.height() != cam_.height) {
        info_.size_mismatch = true;
        return info_;
    }
    FieldContext ctx;
    ctx.field = field_;
    ctx.period_s = cam_.integrationPeriod_s();
    ctx.gain_V =
        cam_.agc == AgcMode::Off || cam_.agc == AgcMode::Bsp || cam_.agc == AgcMode::Autogate
            ? cam_.gain_V
            : agc_.gain_V(field_);
    // 1. optics
    info_.bad_input_px = optics_.apply(lpe, rate_.view(), ctx);
    // 2. gate
    const double scale = cam_.agc == AgcMode::Autogate ? agc_.gateScale(field_) : 1.0;
    ctx.gate_s = gate_.gate_s(ctx.period_s, scale);
    // 3. photocathode
    cathode_.apply(rate_.cview(), sig_.view(), ctx);
    const double cathode_A = ctx.cathodeRate_pe_s * ctx.gate_s / ctx.period_s * 1.602176634e-19;
    // 4. bright-source protection, 5. MCP
    const double bspFactor = bsp_.factor(cathode_A);
    ctx.mcpGain = cam_.mcpGain(ctx.gain_V) * bspFactor;
    if (mcp_.enabled())
        mcp_.apply(sig_.view(), ctx);
    else
        ctx.mcpOut_e = ctx.cathodeRate_pe_s * ctx.gate_s;
    // 6. phosphor, 7. blur, 8. CCD
    phosphor_.apply(sig_.view(), ctx);
    blur_.apply(sig_.view());
    info_.saturated_px = ccd_.apply(sig_.view(), ctx);
    // 9. video
    info_.level_dc = videoStage_.apply(sig_.cview(), field_, counts_.view(), video_.view());
    // 10. AGC loop
    agc_.update(ctx, info_.level_dc);

    info_.t_sample_s = (static_cast<double>(field_) + 0.5) * ctx.period_s;
    info_.gain_V = ctx.gain_V;
    info_.mcp_gain = ctx.mcpGain;
    info_.gate_s = ctx.gate_s;
    info_.bsp_factor = bspFactor;
    info_.cathode_current_A = cathode_A;
    info_.screen_current_A = ctx.mcpOut_e * 1.602176634e-19 / ctx.period_s;
    info_.mean_pe = ctx.cathodeRate_pe_s * ctx.gate_s / (cam_.width * cam_.height);
    ++field_;
    return info_;
}

}  // namespace nvs::sensor
