#include "sim/fit/conv.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <complex>

namespace nvs::fit {

namespace {
// An FFT length ≥ n with prime factors 2, 3, 5 only (FFTW is fastest on these).
int fastLength(int n) {
    for (int m = n;; ++m) {
        int r = m;
        for (int p : {2, 3, 5})
            while (r % p == 0)
                r /= p;
        if (r == 1) return m;
    }
}
}  // namespace

struct Convolver::Impl {
    int w = 0, h = 0, pw = 0, ph = 0, cw = 0;
    double px = 1.0, py = 1.0;
    float* real = nullptr;
    fftwf_complex* spec = nullptr;
    fftwf_plan fwd = nullptr, inv = nullptr;
    std::vector<std::vector<std::complex<float>>> frames;
    std::vector<std::complex<float>> kernel;

    Impl(int width, int height, double pxUm, double pyUm)
        : w(width), h(height), px(pxUm), py(pyUm) {
        pw = fastLength(2 * w);
        ph = fastLength(2 * h);
        cw = pw / 2 + 1;
        real = fftwf_alloc_real(static_cast<std::size_t>(pw) * ph);
        spec = fftwf_alloc_complex(static_cast<std::size_t>(cw) * ph);
        fwd = fftwf_plan_dft_r2c_2d(ph, pw, real, spec, FFTW_ESTIMATE);
        inv = fftwf_plan_dft_c2r_2d(ph, pw, spec, real, FFTW_ESTIMATE);
    }
    ~Impl() {
        fftwf_destroy_plan(fwd);
        fftwf_destroy_plan(inv);
        fftwf_free(real);
        fftwf_free(spec);
    }
    std::size_t nspec() const { return static_cast<std::size_t>(cw) * ph; }
    // The source index of padded index i (padded length np, frame length n): the frame, then
    // its mirror image past the far edge, then (wrapping round) past the near edge.
    static int mirrored(int i, int n, int np) {
        if (i < n) return i;
        const int s = i < n + (np - n) / 2 ? 2 * n - 1 - i : np - 1 - i;
        return std::clamp(s, 0, n - 1);
    }
    void forwardPlane(const Plane& p, std::vector<std::complex<float>>& out) {
        for (int y = 0; y < ph; ++y) {
            const std::size_t row = static_cast<std::size_t>(mirrored(y, h, ph)) * w;
            for (int x = 0; x < pw; ++x)
                real[static_cast<std::size_t>(y) * pw + x] = p[row + mirrored(x, w, pw)];
        }
        fftwf_execute(fwd);
        out.assign(reinterpret_cast<std::complex<float>*>(spec),
                   reinterpret_cast<std::complex<float>*>(spec) + nspec());
    }
    void kernelSpectrum(const std::function<double(double)>& k) {
        // Centred at (0, 0), wrapped: distances to the nearest copy of the origin.
        double sum = 0.0;
        for (int y = 0; y < ph; ++y) {
            const int dy = y <= ph / 2 ? y : y - ph;
            for (int x = 0; x < pw; ++x) {
                const int dx = x <= pw / 2 ? x : x - pw;
                const double v = k(std::hypot(dx * px, dy * py));
                real[static_cast<std::size_t>(y) * pw + x] = static_cast<float>(v);
                sum += v;
            }
        }
        const float norm = sum > 0.0 ? static_cast<float>(1.0 / (sum * pw * ph)) : 0.0f;
        fftwf_execute(fwd);
        kernel.assign(reinterpret_cast<std::complex<float>*>(spec),
                      reinterpret_cast<std::complex<float>*>(spec) + nspec());
        for (auto& c : kernel)
            c *= norm;  // also the 1/(pw·ph) of the unnormalised inverse transform
    }
    void inverseInto(const std::vector<std::complex<float>>& f, Plane& out) {
        auto* s = reinterpret_cast<std::complex<float>*>(spec);
        for (std::size_t i = 0; i < nspec(); ++i)
            s[i] = f[i] * kernel[i];
        fftwf_execute(inv);
        out.resize(static_cast<std::size_t>(w) * h);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                out[static_cast<std::size_t>(y) * w + x] =
                    real[static_cast<std::size_t>(y) * pw + x];
    }
};

Convolver::Convolver(int width, int height, double pitchX_um, double pitchY_um)
    : impl_(std::make_unique<Impl>(width, height, pitchX_um, pitchY_um)) {}
Convolver::~Convolver() = default;

void Convolver::setFrames(const std::vector<Plane>& frames) {
    impl_->frames.resize(frames.size());
    for (std::size_t i = 0; i < frames.size(); ++i)
        impl_->forwardPlane(frames[i], impl_->frames[i]);
}

void Convolver::convolve(const std::function<double(double)>& kernel, std::vector<Plane>& out) {
    impl_->kernelSpectrum(kernel);
    out.resize(impl_->frames.size());
    for (std::size_t i = 0; i < impl_->frames.size(); ++i)
        impl_->inverseInto(impl_->frames[i], out[i]);
}

void Convolver::convolveOne(const Plane& in, const std::function<double(double)>& kernel,
                            Plane& out) {
    std::vector<std::complex<float>> f;
    impl_->forwardPlane(in, f);
    impl_->kernelSpectrum(kernel);
    impl_->inverseInto(f, out);
}

}  // namespace nvs::fit
