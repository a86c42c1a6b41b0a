// frame_grabber_blur: the frame grabber's low-pass along each video line (the thesis's eq. 7.7,
// §7.5): MTF_d(ξ) = exp(−(|ξ|/ξ_d)^n_d) in the horizontal frequency ξ [cycles/mm at the
// photocathode], the same law as the tube's MTF but in one direction only. The digitiser
// samples the analogue line after the CCD and its read-out, so it acts last, on each assembled
// frame's rows (a field's rows and the other field's alike), after the smear. The thesis fitted
// ξ_d = 21.9 cycles/mm and n_d = 0.46 to its bar-target data (docs/validation.md). Chain stage:
// the blur stage's digitiser term, `[mtf] digitiser_fc_cyc_mm` and `digitiser_index`
// (sim/sensor/mtf.cpp, docs/sensor.md stage 7).
//
// The baseline's extra blur is isotropic; a frame blurred along its lines only leaves the
// columns sharper than the rows, which that blur cannot give.

#include <algorithm>
#include <cmath>
#include <vector>

#include "sim/core/simd.h"
#include "sim/fit/effect_registry.h"
#include "sim/fit/text.h"

namespace nvs::fit {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr int kMaxHalfWidth_px = 64;

// The line filter's kernel on the pixel grid: the inverse discrete cosine transform of the MTF
// sampled at the line's frequencies (period 2·kMaxHalfWidth_px + the frame's width, so that the
// kernel does not wrap), truncated where it falls under 1e-5 of its centre, normalised to 1.
std::vector<double> kernel(double fc_cyc_mm, double index, double pitch_mm, int width) {
    const int N = 2 * (width + 2 * kMaxHalfWidth_px);
    std::vector<double> H(static_cast<std::size_t>(N / 2 + 1));
    for (int k = 0; k <= N / 2; ++k) {
        const double f = k / (N * pitch_mm);
        H[static_cast<std::size_t>(k)] = std::exp(-std::pow(f / fc_cyc_mm, index));
    }
    std::vector<double> h(kMaxHalfWidth_px + 1, 0.0);
    for (int x = 0; x <= kMaxHalfWidth_px; ++x) {
        double s = H[0];
        for (int k = 1; k < N / 2; ++k)
            s += 2.0 * H[static_cast<std::size_t>(k)] * std::cos(2.0 * kPi * k * x / N);
        s += H[static_cast<std::size_t>(N / 2)] * std::cos(kPi * x);
        h[static_cast<std::size_t>(x)] = s / N;
    }
    int half = kMaxHalfWidth_px;
    while (half > 0 && std::fabs(h[static_cast<std::size_t>(half)]) < 1e-5 * h[0])
        --half;
    h.resize(static_cast<std::size_t>(half) + 1);
    double sum = h[0];
    for (std::size_t x = 1; x < h.size(); ++x)
        sum += 2.0 * h[x];
    for (double& v : h)
        v /= sum;
    return h;
}

// One row: out[x] = Σ_d h[|d|]·c[x + d], d from −half to half, c padded by half on each side.
// The sum runs tap by tap over the whole row, so that the loop over x has no carried dependency
// and vectorises (in each CPU's widest version, sim/core/simd.h); each pixel's terms are added
// in the same order as a per-pixel sum would add them, so every version gives the same bits.
NVS_SIMD_CLONES void rowKernel(const float* __restrict c, const double* __restrict h, int half,
                               double* __restrict acc, float* __restrict out, int n) {
    for (int x = 0; x < n; ++x)
        acc[x] = h[0] * c[x];
    for (int d = 1; d <= half; ++d) {
        const double hd = h[d];
        const float* up = c + d;
        const float* down = c - d;
        for (int x = 0; x < n; ++x)
            acc[x] += hd * (up[x] + down[x]);
    }
    for (int x = 0; x < n; ++x)
        out[x] = static_cast<float>(acc[x]);
}

// Each row of each frame convolved with the kernel, the row mirrored at its ends (as the
// spatial effects pad, docs/diagnose.md §4). Summed per pixel in scalar code, this effect's
// trial took 18 s of a 112 s diagnosis at 768 x 494 (up to 129 taps).
void apply(const Work& w, const std::vector<double>& p, std::vector<Plane>& S) {
    const std::vector<double> h = kernel(p[0], p[1], w.pitchX_um * 1e-3, w.w);
    const int half = static_cast<int>(h.size()) - 1;
    std::vector<float> row(static_cast<std::size_t>(w.w) + 2 * half);
    std::vector<double> acc(static_cast<std::size_t>(w.w));
    for (Plane& P : S)
        for (int y = 0; y < w.h; ++y) {
            float* r = P.data() + static_cast<std::size_t>(y) * w.w;
            for (int x = -half; x < w.w + half; ++x) {
                int xs = x < 0 ? -x - 1 : x >= w.w ? 2 * w.w - 1 - x : x;
                xs = std::clamp(xs, 0, w.w - 1);
                row[static_cast<std::size_t>(x + half)] = r[xs];
            }
            rowKernel(row.data() + half, h.data(), half, acc.data(), r, w.w);
        }
}

bool present(const sensor::CameraParams& cam) {
    return cam.mtf_enabled && cam.digitiser_fc_cyc_mm > 0.0;
}

std::string cause(const std::vector<double>& p) {
    return textf(
        "the frame grabber blurs each video line: exp(-(f/%.3g cycles/mm)^%.3g) "
        "horizontally (thesis eq. 7.7), which the model does not have",
        p[0], p[1]);
}

}  // namespace

const RegisteredEffect& frameGrabberBlur() {
    static const RegisteredEffect e{
        "frame_grabber_blur",
        "blur (stage 7), the digitiser's horizontal MTF: [mtf] digitiser_fc_cyc_mm, "
        "digitiser_index",
        {{"fc_cyc_mm", "mtf.digitiser_fc_cyc_mm", "cycles/mm", 2.0, 300.0, 12.0, 30.0},
         {"index", "mtf.digitiser_index", "1", 0.25, 4.0, 0.4, 1.2}},
        present,
        apply,
        cause};
    return e;
}

}  // namespace nvs::fit
