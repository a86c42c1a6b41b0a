#include "sim/sensor/stages/blur.h"

#include <fftw3.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/core/fft_plans.h"
#include "sim/core/simd.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/mtf.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

void BlurParams::read(const PresetReader& root) {
    const PresetReader mtf = root.sub("mtf");
    mtf_enabled = mtf.get<bool>("enabled", mtf_enabled);
    ii_fc_cyc_mm = nonNegative(mtf, "ii_fc_cyc_mm", ii_fc_cyc_mm);
    ii_index = positive(mtf, "ii_index", ii_index);
    fibre_pitch_um = nonNegative(mtf, "fibre_pitch_um", fibre_pitch_um);
    ccd_aperture_mtf = mtf.get<bool>("ccd_aperture", ccd_aperture_mtf);
    digitiser_fc_cyc_mm = nonNegative(mtf, "digitiser_fc_cyc_mm", digitiser_fc_cyc_mm);
    digitiser_index = positive(mtf, "digitiser_index", digitiser_index);
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
    // every CPU), else FFTW_ESTIMATE's among scalar solvers (sim/core/fft_plans.h);
    // FFTW_MEASURE / FFTW_PATIENT on request only (a measured plan can differ from run to run and
    // so break bit-exact replay).
    importShippedFftWisdom(configDir);
    const unsigned flags = fftPlannerFlags(opt.patientFft   ? FftPlanning::Patient
                                           : opt.measureFft ? FftPlanning::Measure
                                                            : FftPlanning::Shipped);
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
    fft_->rowFwd = planFromWisdomOrEstimate(
        [&](unsigned f) { return fftwf_plan_dft_r2c_1d(wp_, r, sp, f); }, flags, "blur");
    fft_->rowInv = planFromWisdomOrEstimate(
        [&](unsigned f) { return fftwf_plan_dft_c2r_1d(wp_, sp, r, f); }, flags, "blur");
    // Column bands: cb_ columns each, the last one what is left.
    const int last = wc_ - (wc_ - 1) / cb_ * cb_;
    for (int i = 0; i < 2; ++i) {
        int n[1] = {hp_};
        const int howmany = i == 0 ? cb_ : last;
        for (int sign : {FFTW_FORWARD, FFTW_BACKWARD}) {
            fftwf_plan p = planFromWisdomOrEstimate(
                [&](unsigned f) {
                    return fftwf_plan_many_dft(1, n, howmany, sp, nullptr, wcs_, 1, sp, nullptr,
                                               wcs_, 1, sign, f);
                },
                flags, "blur");
            (sign == FFTW_FORWARD ? fft_->colFwd : fft_->colInv)[i] = p;
        }
    }
}

BlurStage::~BlurStage() = default;

bool BlurStage::exportWisdom(const std::filesystem::path& file) {
    return exportFftWisdom(file);
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
NVS_SIMD_CLONES void applyFilterKernel(fftwf_complex* __restrict s, const float* __restrict f,
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

}  // namespace nvs::sensor
