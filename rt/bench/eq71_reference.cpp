#include "rt/bench/eq71_reference.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <numbers>

#include "sim/core/error.h"

namespace nvs::rt::bench {

Eq71Reference::Eq71Reference(const Eq71Params& p) : p_(p), rng_(p.seed) {
    if (p.width < 2 || p.height < 2) throw SetupError("eq. 7.1 reference: frame too small");
    if (p.adc_bits < 1 || p.adc_bits > 16) throw SetupError("eq. 7.1 reference: adc_bits");
    if (!(p.mtf_sigma_px >= 0.0) || !(p.pe_per_input >= 0.0) || !(p.noise_dc >= 0.0)) {
        throw SetupError("eq. 7.1 reference: negative parameter");
    }
    const int w = p.width, h = p.height, wc = w / 2 + 1;
    image_.assign(static_cast<std::size_t>(w) * h, 0.0);
    spectrum_ = fftw_malloc(sizeof(fftw_complex) * static_cast<std::size_t>(wc) * h);
    auto* spec = static_cast<fftw_complex*>(spectrum_);
    // FFTW's 2-d real transforms take the slow dimension first (FFTW 3 manual §4.3.4).
    forward_ = fftw_plan_dft_r2c_2d(h, w, image_.data(), spec, FFTW_ESTIMATE);
    inverse_ = fftw_plan_dft_c2r_2d(h, w, spec, image_.data(), FFTW_ESTIMATE);
    if (forward_ == nullptr || inverse_ == nullptr) {
        throw SetupError("eq. 7.1 reference: FFTW planning failed");
    }
    // The filter on FFTW's half spectrum: row ky holds frequency ky/h (or (ky − h)/h above
    // Nyquist), column kx frequency kx/w. FFTW's transforms are unnormalised: the round trip
    // multiplies by w·h, which the filter divides out.
    mtf_.resize(static_cast<std::size_t>(wc) * h);
    const double twoPi2s2 =
        2.0 * std::numbers::pi * std::numbers::pi * p.mtf_sigma_px * p.mtf_sigma_px;
    for (int ky = 0; ky < h; ++ky) {
        const double fy = (ky <= h / 2 ? ky : ky - h) / static_cast<double>(h);
        for (int kx = 0; kx < wc; ++kx) {
            const double fx = kx / static_cast<double>(w);
            mtf_[static_cast<std::size_t>(ky) * wc + kx] =
                std::exp(-twoPi2s2 * (fx * fx + fy * fy)) / (static_cast<double>(w) * h);
        }
    }
}

Eq71Reference::~Eq71Reference() {
    fftw_destroy_plan(static_cast<fftw_plan>(forward_));
    fftw_destroy_plan(static_cast<fftw_plan>(inverse_));
    fftw_free(spectrum_);
}

void Eq71Reference::process(const float* in, std::uint16_t* out) {
    const std::size_t n = image_.size();
    // Shot noise: a Poisson count around each pixel's mean (thesis eq. 6.25, §6.4.1).
    for (std::size_t i = 0; i < n; ++i) {
        std::poisson_distribution<int> shot(static_cast<double>(in[i]) * p_.pe_per_input);
        image_[i] = shot(rng_);
    }
    // The MTF, applied in the frequency domain (eq. 7.1).
    fftw_execute(static_cast<fftw_plan>(forward_));
    auto* spec = static_cast<fftw_complex*>(spectrum_);
    for (std::size_t k = 0; k < mtf_.size(); ++k) {
        spec[k][0] *= mtf_[k];
        spec[k][1] *= mtf_[k];
    }
    fftw_execute(static_cast<fftw_plan>(inverse_));
    // Gain, bias, Gaussian noise (§6.4.2), clipped to the ADC and rounded.
    std::normal_distribution<double> noise(0.0, p_.noise_dc);
    const double top = std::ldexp(1.0, p_.adc_bits) - 1.0;
    for (std::size_t i = 0; i < n; ++i) {
        double v = p_.gain_dc_per_pe * image_[i] + p_.bias_dc;
        if (p_.noise_dc > 0.0) v += noise(rng_);
        out[i] = static_cast<std::uint16_t>(std::lround(std::clamp(v, 0.0, top)));
    }
}

}  // namespace nvs::rt::bench
