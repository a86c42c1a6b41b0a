#include "sim/sensor/stages/video.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/core/simd.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

void VideoParams::read(const PresetReader& root) {
    const PresetReader video = root.sub("video");
    video_gain_dc_per_e = positive(video, "gain_dc_per_e", video_gain_dc_per_e);
    video_offset_dc = video.get<double>("offset_dc", video_offset_dc);
    video_noise_dc = nonNegative(video, "noise_dc", video_noise_dc);
    gamma = positive(video, "gamma", gamma);
    adc_bits = video.get<int>("adc_bits", adc_bits);
    require(adc_bits >= 1 && adc_bits <= 16, video, "adc_bits", "must be in 1..16");
    streak_fraction = nonNegative(video, "streak_fraction", streak_fraction);
    require(streak_fraction < 1.0, video, "streak_fraction", "must be below 1");
    streak_tau_px = positive(video, "streak_tau_px", streak_tau_px);
    const std::string scanMode = video.get<std::string>("scan", "field");
    if (scanMode == "field")
        scan = ScanMode::Field;
    else if (scanMode == "frame")
        scan = ScanMode::Frame;
    else
        video.fail("scan", "must be field or frame");
    const std::string order = video.get<std::string>("field_order", "top");
    if (order != "top" && order != "bottom") video.fail("field_order", "must be top or bottom");
    topFieldFirst = order == "top";
}

namespace {

// Video, linear, one value: round to nearest even by the 1.5·2²³ trick (exact for |x| < 2²²;
// the value is clamped to [−1, max + 1] first), then clamp to the ADC range.
inline __attribute__((always_inline)) float linearCount(float s, float gain, float offset,
                                                        float maxc) noexcept {
    float dc = s * gain + offset;
    dc = dc < -1.0f ? -1.0f : dc;
    dc = dc > maxc + 1.0f ? maxc + 1.0f : dc;
    dc = (dc + 0x1.8p23f) - 0x1.8p23f;
    dc = dc < 0.0f ? 0.0f : dc;
    return dc > maxc ? maxc : dc;
}

// Video, linear: linearCount of every pixel. Returns the row's sum.
NVS_SIMD_CLONES std::int64_t videoLinearKernel(const float* __restrict s, float* __restrict o,
                                               std::uint16_t* __restrict v, int w, float gain,
                                               float offset, float maxc) noexcept {
    std::int32_t sum = 0;
    for (int x = 0; x < w; ++x) {
        const float dc = linearCount(s[x], gain, offset, maxc);
        o[x] = dc;
        const std::int32_t n = static_cast<std::int32_t>(dc);
        v[x] = static_cast<std::uint16_t>(n);
        sum += n;
    }
    return sum;
}

// Video, gamma with a one-step threshold table (VideoStage): signals above zero take the
// table's level, the others the linear conversion.
NVS_SIMD_CLONES std::int64_t videoGammaKernel(const float* __restrict s, float* __restrict o,
                                              std::uint16_t* __restrict v, int w, float gain,
                                              float offset, float maxc,
                                              const std::int32_t* __restrict lut,
                                              const float* __restrict thr, float lutScale,
                                              float top, float bottom) noexcept {
    std::int32_t sum = 0;
    for (int x = 0; x < w; ++x) {
        const float dc = linearCount(s[x], gain, offset, maxc);
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

}  // namespace

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

void VideoStage::droopRow(const float* e, float* out, int w, double fraction,
                          double tau_px) noexcept {
    // A recursion along the line: the running mean is the state of the coupling's RC circuit,
    // one multiply-add a pixel (a convolution with the exponential would cost τ of them).
    const double r = std::exp(-1.0 / tau_px);
    double m = 0.0;
    for (int x = 0; x < w; ++x) {
        const double in = e[x];
        out[x] = static_cast<float>(in - fraction * m);
        m = r * m + (1.0 - r) * in;
    }
}

float VideoStage::countOf(float s) const noexcept {
    const CameraParams& c = *cam_;
    const float gain = static_cast<float>(c.video_gain_dc_per_e);
    const float offset = static_cast<float>(c.video_offset_dc);
    const float maxc = static_cast<float>(maxCount_);
    const float sig = s * gain;
    if (!gamma_ || !(sig > 0.0f)) return linearCount(s, gain, offset, maxc);
    const float bottom = std::clamp(std::nearbyint(offset), 0.0f, maxc);
    const int cells = static_cast<int>(lut_.size()) - 1;
    const int cell = std::min(static_cast<int>(sig * lutScale_), cells);
    std::size_t j = static_cast<std::size_t>(lut_[static_cast<std::size_t>(cell)]);
    while (thr_[j] <= sig)
        ++j;
    return std::min(bottom + static_cast<float>(j), maxc);
}

std::int64_t VideoStage::countRow(const float* s, float* o, std::uint16_t* v,
                                  int w) const noexcept {
    std::int64_t sum = 0;
    for (int x = 0; x < w; ++x) {
        o[x] = countOf(s[x]);
        v[x] = static_cast<std::uint16_t>(static_cast<std::int32_t>(o[x]));
        sum += v[x];
    }
    return sum;
}

std::int64_t VideoStage::applyRow(const float* s, float* o, std::uint16_t* v,
                                  int w) const noexcept {
    const CameraParams& c = *cam_;
    if (c.streak_fraction > 0.0) {
        // The droop first, into the counts row, then each pixel converted where it lies.
        droopRow(s, o, w, c.streak_fraction, c.streak_tau_px);
        return countRow(o, o, v, w);
    }
    const float gain = static_cast<float>(c.video_gain_dc_per_e);
    const float offset = static_cast<float>(c.video_offset_dc);
    const float maxc = static_cast<float>(maxCount_);
    if (!gamma_) return videoLinearKernel(s, o, v, w, gain, offset, maxc);
    if (!oneStep_) return countRow(s, o, v, w);  // a grid cell holds two steps: the search
    const float bottom = std::clamp(std::nearbyint(offset), 0.0f, maxc);
    return videoGammaKernel(s, o, v, w, gain, offset, maxc, lut_.data(), thr_.data(), lutScale_,
                            static_cast<float>(lut_.size() - 1), bottom);
}

}  // namespace nvs::sensor
