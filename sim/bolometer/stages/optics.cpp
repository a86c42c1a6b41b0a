#include "sim/bolometer/stages/optics.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <vector>

#include "sim/bolometer/camera.h"
#include "sim/core/fft_plans.h"
#include "sim/core/planck.h"
#include "sim/core/simd.h"

namespace nvs::bolometer {

void OpticsParams::read(const Reader& root) {
    const Reader o = root.sub("optics");
    f_number = positive(o, "f_number", f_number);
    optics_transmission = positive(o, "transmission", optics_transmission);
    require(optics_transmission <= 1.0, o, "transmission", "must be <= 1");
    fill_factor = positive(o, "fill_factor", fill_factor);
    require(fill_factor <= 1.0, o, "fill_factor", "must be <= 1");
    mtf_enabled = o.get<bool>("mtf", mtf_enabled);
}

namespace {
constexpr double kPi = 3.14159265358979323846;
constexpr int kBandSamples = 13;  // wavelengths across the band (Simpson)

double circularMtf(double s) {
    if (s >= 1.0) return 0.0;
    return 2.0 / kPi * (std::acos(s) - s * std::sqrt(1.0 - s * s));
}
double sinc(double x) {
    return x == 0.0 ? 1.0 : std::sin(kPi * x) / (kPi * x);
}
}  // namespace

double bandDiffractionMtf(double nu_cyc_m, double fNumber, double lo_um, double hi_um) {
    // Simpson's rule over the band, weight L_λ(λ, 300 K).
    double num = 0.0, den = 0.0;
    for (int i = 0; i < kBandSamples; ++i) {
        const double lambda_m = (lo_um + (hi_um - lo_um) * i / (kBandSamples - 1)) * 1e-6;
        const double wS = (i == 0 || i == kBandSamples - 1) ? 1.0 : (i % 2 ? 4.0 : 2.0);
        const double w = wS * planckSpectralRadiance_W_m2_sr_m(lambda_m, 300.0);
        num += w * circularMtf(nu_cyc_m * lambda_m * fNumber);
        den += w;
    }
    return num / den;
}

struct OpticsStage::Fft {
    float* real = nullptr;  // hp × wp, the mirrored image
    fftwf_complex* spec = nullptr;
    float* transfer = nullptr;  // hp × (wp/2 + 1), H/(wp·hp)
    fftwf_plan fwd = nullptr, inv = nullptr;
    ~Fft() {
        if (fwd) fftwf_destroy_plan(fwd);
        if (inv) fftwf_destroy_plan(inv);
        fftwf_free(real);
        fftwf_free(spec);
        fftwf_free(transfer);
    }
};

namespace {
// FFT length for m pixels with a mirrored margin of at least 16 on each side: the first
// multiple of 32 with prime factors 2, 3, 5, 7 only.
int fastSize(int m) {
    for (int n = (m + 32 + 31) / 32 * 32;; n += 32) {
        int r = n;
        for (int p : {2, 3, 5, 7})
            while (r % p == 0)
                r /= p;
        if (r == 1) return n;
    }
}
// Source pixel of padded position i (n pixels, np padded): past the end the image mirrors its
// last pixels, near the (periodic) end its first ones, the two mirrors meeting half-way.
int mirror(int i, int n, int np) {
    if (i < n) return i;
    const int beyond = i - n, half = (np - n) / 2;
    return std::clamp(beyond < half ? n - 1 - beyond : np - i - 1, 0, n - 1);
}
}  // namespace

OpticsStage::OpticsStage(const ThermalCameraParams& cam, const std::filesystem::path& configDir,
                         FftPlanning planning)
    : w_(cam.width),
      h_(cam.height),
      wattsPerRadiance_(
          static_cast<float>(cam.wattsPerRadiance(cam.f_number, cam.optics_transmission))),
      wattsPerRadianceOpen_(static_cast<float>(cam.wattsPerRadiance(cam.f_number, 1.0))) {
    if (cam.mtf_enabled) buildTransfer(cam, configDir, planning);
}

OpticsStage::~OpticsStage() = default;

void OpticsStage::buildTransfer(const ThermalCameraParams& cam,
                                const std::filesystem::path& configDir, FftPlanning planning) {
    wp_ = fastSize(w_);
    hp_ = fastSize(h_);
    const int wc = wp_ / 2 + 1;
    fft_ = std::make_unique<Fft>();
    const std::size_t nr = static_cast<std::size_t>(wp_) * hp_;
    const std::size_t nc = static_cast<std::size_t>(wc) * hp_;
    fft_->real = fftwf_alloc_real(nr);
    fft_->spec = fftwf_alloc_complex(nc);
    fft_->transfer = fftwf_alloc_real(nc);
    if (!fft_->real || !fft_->spec || !fft_->transfer) throw SetupError("optics: out of memory");
    // Plans from the shipped wisdom (SSE2 codelets, made for the shipped presets' sizes), else
    // FFTW_ESTIMATE among the scalar solvers: either way the same plan, and bits, on every x86-64
    // CPU (sim/core/fft_plans.h, docs/portability.md). For boson-640 the wisdom's round trip
    // took 2.6 ms against the scalar estimate's 5.4 ms (docs/portability.md).
    // Without a config folder the scalar estimate directly: wisdom another chain imported into
    // this process is not used either, so the plan does not depend on what ran before.
    importShippedFftWisdom(configDir);
    const unsigned flags = configDir.empty() && planning == FftPlanning::Shipped
                               ? FFTW_ESTIMATE | FFTW_NO_SIMD | FFTW_DESTROY_INPUT
                               : fftPlannerFlags(planning, FFTW_DESTROY_INPUT);
    float* re = fft_->real;
    fftwf_complex* sp = fft_->spec;
    bool fwdShipped = false, invShipped = false;
    fft_->fwd = planFromWisdomOrEstimate(
        [&](unsigned f) { return fftwf_plan_dft_r2c_2d(hp_, wp_, re, sp, f); }, flags, "optics",
        &fwdShipped);
    fft_->inv = planFromWisdomOrEstimate(
        [&](unsigned f) { return fftwf_plan_dft_c2r_2d(hp_, wp_, sp, re, f); }, flags, "optics",
        &invShipped);
    plannedFromWisdom_ =
        !configDir.empty() && planning == FftPlanning::Shipped && fwdShipped && invShipped;
    // The band-averaged diffraction MTF tabulated over [0, νc] (linear interpolation).
    const double p_m = cam.pitch_um * 1e-6, a_m = p_m * std::sqrt(cam.fill_factor);
    const double nuC = 1.0 / (cam.band_lo_um * 1e-6 * cam.f_number);
    constexpr int kTable = 4096;
    std::vector<double> diff(kTable + 1);
    for (int i = 0; i <= kTable; ++i)
        diff[i] =
            bandDiffractionMtf(nuC * i / kTable, cam.f_number, cam.band_lo_um, cam.band_hi_um);
    // H at (kx, ky): Σ over the aliases; the pixel's sincs tabulated per alias and index.
    // Aliases up to the cut-off: |ν + m/p| < νc needs |m| ≤ νc·p + ½ (2 for f/1, 12 µm).
    const int kAlias = static_cast<int>(std::ceil(nuC * p_m + 0.5)), kTerms = 2 * kAlias + 1;
    const auto diffAt = [&](double vx, double vy) {
        const double t = std::sqrt(vx * vx + vy * vy) / nuC * kTable;
        if (t >= kTable) return 0.0;
        const int i = static_cast<int>(t);
        return diff[i] + (diff[i + 1] - diff[i]) * (t - i);
    };
    std::vector<double> vxs(static_cast<std::size_t>(wc) * kTerms), sx(vxs.size());
    for (int kx = 0; kx < wc; ++kx)
        for (int m = 0; m < kTerms; ++m) {
            const double v = kx / (wp_ * p_m) + (m - kAlias) / p_m;
            vxs[kx * kTerms + m] = v;
            sx[kx * kTerms + m] = sinc(a_m * v);
        }
    const auto sampled = [&](int kx, double vy0) {
        double s = 0.0;
        for (int my = -kAlias; my <= kAlias; ++my) {
            const double vy = vy0 + my / p_m, sy = sinc(a_m * vy);
            for (int m = 0; m < kTerms; ++m)
                s += diffAt(vxs[kx * kTerms + m], vy) * sx[kx * kTerms + m] * sy;
        }
        return s;
    };
    const double norm = sampled(0, 0.0) * static_cast<double>(nr);
    for (int ky = 0; ky < hp_; ++ky) {
        const double vy = (ky <= hp_ / 2 ? ky : ky - hp_) / (hp_ * p_m);
        for (int kx = 0; kx < wc; ++kx)
            fft_->transfer[static_cast<std::size_t>(ky) * wc + kx] =
                static_cast<float>(sampled(kx, vy) / norm);
    }
}

NVS_SIMD_CLONES int OpticsStage::apply(ImageView<const float> radiance,
                                       ImageView<float> power_W) noexcept {
    // Scale to power; NaN, ±inf and negative pixels count as 0. With the MTF on, straight into
    // the FFT's padded buffer: one pass over the image fewer than scaling into power_W and
    // copying it there (the same products, so the same bits).
    int bad = 0;
    for (int y = 0; y < h_; ++y) {
        const float* s = radiance.row(y);
        float* d = fft_ ? fft_->real + static_cast<std::size_t>(y) * wp_ : power_W.row(y);
        const float k = wattsPerRadiance_;
        for (int x = 0; x < w_; ++x) {  // branch-free (bitwise &), so that it vectorises
            const float v = s[x];
            const bool ok = (v >= 0.0f) & (v <= 3.4e38f);  // false for NaN
            bad += static_cast<int>(!ok);
            d[x] = ok ? v * k : 0.0f;
        }
    }
    if (fft_) filter(power_W);
    return bad;
}

NVS_SIMD_CLONES void OpticsStage::filter(ImageView<float> img) noexcept {
    // The image's rows are in the padded buffer (apply): mirror-pad each row's margin, then the
    // rows below the image as mirrored copies of padded rows; transform, multiply by H,
    // transform back, keep the image's pixels.
    float* re = fft_->real;
    for (int y = 0; y < h_; ++y) {
        float* d = re + static_cast<std::size_t>(y) * wp_;
        for (int x = w_; x < wp_; ++x)
            d[x] = d[mirror(x, w_, wp_)];
    }
    for (int y = h_; y < hp_; ++y) {
        const float* s = re + static_cast<std::size_t>(mirror(y, h_, hp_)) * wp_;
        std::copy(s, s + wp_, re + static_cast<std::size_t>(y) * wp_);
    }
    fftwf_execute(fft_->fwd);
    const std::size_t nc = static_cast<std::size_t>(wp_ / 2 + 1) * hp_;
    fftwf_complex* c = fft_->spec;
    const float* t = fft_->transfer;
    for (std::size_t i = 0; i < nc; ++i) {
        c[i][0] *= t[i];
        c[i][1] *= t[i];
    }
    fftwf_execute(fft_->inv);
    for (int y = 0; y < h_; ++y) {
        const float* s = re + static_cast<std::size_t>(y) * wp_;
        float* d = img.row(y);
        for (int x = 0; x < w_; ++x)
            d[x] = s[x] > 0.0f ? s[x] : 0.0f;  // ringing below zero removed
    }
}

void OpticsStage::uniform(double radiance_W_m2_sr, ImageView<float> power_W) const noexcept {
    power_W.fill(static_cast<float>(radiance_W_m2_sr * static_cast<double>(wattsPerRadianceOpen_)));
}

}  // namespace nvs::bolometer
