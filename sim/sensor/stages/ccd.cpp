#include "sim/sensor/stages/ccd.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <vector>

#include "sim/core/rng.h"
#include "sim/core/simd.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

void CcdParams::read(const PresetReader& root) {
    const PresetReader ccd = root.sub("ccd");
    pitch_x_um = positive(ccd, "pitch_x_um", pitch_x_um);
    pitch_y_um = positive(ccd, "pitch_y_um", pitch_y_um);
    full_well_e = nonNegative(ccd, "full_well_e", full_well_e);
    const std::string arch = ccd.get<std::string>("architecture", "full_frame");
    if (arch == "interline")
        architecture = CcdArchitecture::Interline;
    else if (arch == "frame_transfer")
        architecture = CcdArchitecture::FrameTransfer;
    else if (arch == "full_frame")
        architecture = CcdArchitecture::FullFrame;
    else
        ccd.fail("architecture", "must be interline, frame_transfer or full_frame");
    const bool interline = architecture == CcdArchitecture::Interline;
    const std::string bl = ccd.get<std::string>("bloom", "vertical");
    if (bl == "off")
        bloom = BloomDirection::Off;
    else if (bl == "vertical")
        bloom = BloomDirection::Vertical;
    else if (bl == "horizontal")
        bloom = BloomDirection::Horizontal;
    else
        ccd.fail("bloom", "must be off, vertical or horizontal");
    if (interline && (ccd.inFile("bloom") || ccd.overridden("bloom")))
        ccd.fail("bloom",
                 "an interline CCD drains its overload (set overload_x); bloom is for "
                 "frame_transfer and full_frame");
    // Beyond the drain's capacity the charge spills into the vertical register: along columns.
    if (interline) bloom = BloomDirection::Vertical;
    overload_x = positive(ccd, "overload_x", overload_x);
    require(overload_x >= 1.0, ccd, "overload_x", "must be >= 1 (a multiple of full_well_e)");
    const double smearDb = ccd.get<double>("smear_dB", 0.0);
    // smear_dB is the interline datasheet's figure (a frame-transfer or full-frame CCD's smear,
    // from its transfer time, is smear_rel): ignored when the architecture is overridden.
    if (interline && (ccd.inFile("smear_dB") || ccd.overridden("smear_dB"))) {
        require(std::isfinite(smearDb) && smearDb < 0.0, ccd, "smear_dB", "must be < 0 dB");
        smear_rel = smearRelFromDb(smearDb);
    }
    smear_rel = nonNegative(ccd, "smear_rel", smear_rel);  // a fit's smear_rel overrides
    dark_e_s = nonNegative(ccd, "dark_e_s", dark_e_s);
    read_noise_e = nonNegative(ccd, "read_noise_e", read_noise_e);
    prnu_rel = nonNegative(ccd, "prnu_rel", prnu_rel);
    require(prnu_rel < 0.5, ccd, "prnu_rel", "must be < 0.5");
    prnu_blotch_rel = nonNegative(ccd, "prnu_blotch_rel", prnu_blotch_rel);
    require(prnu_blotch_rel < 0.5, ccd, "prnu_blotch_rel", "must be < 0.5");
    prnu_blotch_sigma_px = nonNegative(ccd, "prnu_blotch_sigma_px", prnu_blotch_sigma_px);
    require(
        prnu_blotch_rel == 0.0 || (prnu_blotch_sigma_px >= 0.5 && prnu_blotch_sigma_px <= 200.0),
        ccd, "prnu_blotch_sigma_px", "must be in [0.5, 200] px where prnu_blotch_rel > 0");
}

namespace {

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
NVS_SIMD_CLONES void ccdLoadKernel(const float* __restrict src, const float* __restrict prnu,
                                   float* __restrict dst, float* __restrict cmax,
                                   float* __restrict csum, int w, float dark) noexcept {
    ccdLoadBody<true>(src, prnu, dst, cmax, csum, w, dark);
}
NVS_SIMD_CLONES void ccdLoadMaxKernel(const float* __restrict src, const float* __restrict prnu,
                                      float* __restrict dst, float* __restrict cmax, int w,
                                      float dark) noexcept {
    ccdLoadBody<false>(src, prnu, dst, cmax, nullptr, w, dark);
}

// Column sums of a row: cs += v.
NVS_SIMD_CLONES void addRowKernel(const float* __restrict v, float* __restrict cs, int w) noexcept {
    for (int x = 0; x < w; ++x)
        cs[x] += v[x];
}

// Interline overflow drain: a cell keeps min(v, fw), plus what exceeds the drain's capacity
// (v − cap, which then blooms along the column).
NVS_SIMD_CLONES void drainKernel(float* __restrict v, int w, float fw, float cap) noexcept {
    for (int x = 0; x < w; ++x) {
        const float c = v[x];
        const float over = c - cap;
        const float kept = c < fw ? c : fw;
        v[x] = kept + (over > 0.0f ? over : 0.0f);
    }
}

// Read-out row: v += smear + σ·z.
NVS_SIMD_CLONES void ccdReadKernel(float* __restrict v, const float* __restrict cs,
                                   const float* __restrict z, int w, float sigma) noexcept {
    for (int x = 0; x < w; ++x)
        v[x] += cs[x] + sigma * z[x];
}

}  // namespace

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
    if (c.prnu_rel > 0.0 || c.prnu_blotch_rel > 0.0) {
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
        if (c.prnu_blotch_rel > 0.0) multiplyBlotches(c, rng);
    }
    const double video_e = c.video_noise_dc / c.video_gain_dc_per_e;
    noiseSigma_e_ = std::sqrt(c.read_noise_e * c.read_noise_e + video_e * video_e);
}

// The blotch pattern (CcdParams::prnu_blotch_rel): a second plane of the fixed-pattern stream,
// blurred by a separable Gaussian (edges mirrored) and scaled to zero mean and unit rms over the
// frame, multiplies the cell pattern. Setup only; a direct convolution, as the kernel is short
// against the frame and runs once.
void CcdStage::multiplyBlotches(const CameraParams& c, const PixelRng& rng) {
    const int w = c.width, h = c.height;
    const double sigma = c.prnu_blotch_sigma_px;
    const int r = static_cast<int>(std::ceil(4.0 * sigma));
    std::vector<double> k(static_cast<std::size_t>(2 * r + 1));
    for (int i = -r; i <= r; ++i)
        k[static_cast<std::size_t>(i + r)] = std::exp(-0.5 * i * i / (sigma * sigma));
    std::vector<double> z(static_cast<std::size_t>(w) * h), t(z.size());
    for (int y = 0; y < h; ++y) {
        rng.rowWords(static_cast<std::uint32_t>(y), 1, 0, blocksFor(w), words_.get());
        normalsFromWords(words_.get(), z_.get(), w);
        for (int x = 0; x < w; ++x)
            z[static_cast<std::size_t>(y) * w + x] = z_[x];
    }
    const auto mirror = [](int i, int n) {
        while (i < 0 || i >= n)
            i = i < 0 ? -i - 1 : 2 * n - i - 1;
        return i;
    };
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double s = 0.0;
            for (int i = -r; i <= r; ++i)
                s += k[static_cast<std::size_t>(i + r)] *
                     z[static_cast<std::size_t>(y) * w + mirror(x + i, w)];
            t[static_cast<std::size_t>(y) * w + x] = s;
        }
    double sum = 0.0, sum2 = 0.0;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            double s = 0.0;
            for (int i = -r; i <= r; ++i)
                s += k[static_cast<std::size_t>(i + r)] *
                     t[static_cast<std::size_t>(mirror(y + i, h)) * w + x];
            z[static_cast<std::size_t>(y) * w + x] = s;
            sum += s;
            sum2 += s * s;
        }
    const double n = static_cast<double>(w) * h;
    const double mean = sum / n, rms = std::sqrt(std::max(sum2 / n - mean * mean, 1e-300));
    for (int y = 0; y < h; ++y) {
        float* p = prnu_.row(y);
        for (int x = 0; x < w; ++x) {
            const double b = (z[static_cast<std::size_t>(y) * w + x] - mean) / rms;
            p[x] = static_cast<float>(static_cast<double>(p[x]) * (1.0 + c.prnu_blotch_rel * b));
        }
    }
}

namespace {
// One cell of a blooming sweep: the charge moving along the line fills the cell up to full
// well, and what does not fit moves on.
inline void fillToWell(float& cell, float& moving, float fullWell) noexcept {
    if (moving > 0.0f) {
        const float take = std::min(fullWell - cell, moving);
        cell += take;
        moving -= take;
    }
}
}  // namespace

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
        fillToWell(c, moving, fw);
        moving += carry[i];
    }
    moving = 0.0f;
    for (int i = n - 1; i >= 0; --i) {
        float& c = v[i * step];
        fillToWell(c, moving, fw);
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
NVS_SIMD_CLONES void bloomDownKernel(float* __restrict v, float* __restrict moving,
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
NVS_SIMD_CLONES int bloomUpKernel(float* __restrict v, float* __restrict moving,
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

void CcdStage::drainRow(float* v) const noexcept {
    const CameraParams& c = *cam_;
    if (c.architecture != CcdArchitecture::Interline || !(c.full_well_e > 0.0)) return;
    drainKernel(v, c.width, static_cast<float>(c.full_well_e),
                static_cast<float>(c.overload_x * c.full_well_e));
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
    // Interline: the overflow drain, after the column sums (smear comes from the light the
    // column sees, drained or not).
    drainRow(dst);
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
    if (cam_->architecture == CcdArchitecture::Interline) {
        for (int y = 0; y < e.height(); ++y)
            drainRow(e.row(y));
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
            // Interline: the smear sums stay those of the light (before the drain).
            const bool resum = smear && c.architecture != CcdArchitecture::Interline;
            saturated += bloomColumns(e, fw, cmax, resum ? cs : nullptr);
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

}  // namespace nvs::sensor
