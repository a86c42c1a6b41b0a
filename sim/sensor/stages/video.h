#pragma once
// Step 9, video (docs/sensor.md): gain, offset, gamma, interlace and the ADC.

#include <cstdint>
#include <vector>

#include "sim/core/image.h"
#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;

enum class ScanMode { Frame, Field };

struct VideoParams {
    ScanMode scan = ScanMode::Field;
    // Field scan: which field comes first in time. Top: field 0 (and every even field) holds
    // rows 0, 2, 4, …; bottom: rows 1, 3, 5, … (y4m "It" / "Ib", V4L2_FIELD_INTERLACED_TB/BT).
    bool topFieldFirst = true;
    // --- 9. Video -------------------------------------------------------------------------
    double video_gain_dc_per_e = 0.004;  // [DC/e]
    double video_offset_dc = 26.0;       // [DC]
    double video_noise_dc = 0.0;         // [DC rms] additive pre-amplifier noise
    double gamma = 1.0;                  // Table 11-2: gamma 1.0
    int adc_bits = 8;
    // The line's droop through an AC-coupled video path (a coupling capacitor, the level
    // clamped to black at each line's back porch): along each line the signal less the
    // fraction streak_fraction of its running mean, a first-order low-pass of time constant
    // streak_tau_px pixels started at 0 at the line's start. A bright object drags the level
    // after it down (a dark streak to its right) and a flat line droops from left to right.
    // At 768 active pixels in RS-170's 52.6 µs line, one pixel is 68.5 ns. 0 = off.
    double streak_fraction = 0.0;
    double streak_tau_px = 20.0;  // [px]

    // Reads [video] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
};

// ---- 9. Video -------------------------------------------------------------------------------
class VideoStage {
  public:
    explicit VideoStage(const CameraParams& cam);
    // Writes the rows of this field into the output frame; returns the mean output level.
    double apply(ImageView<const float> e, std::uint64_t field, ImageView<float> counts,
                 ImageView<std::uint16_t> video) const noexcept;
    int maxCount() const { return maxCount_; }
    // Whether row y is read out in this field, and that row's conversion (returns the sum of
    // its output counts); apply() is the mean over the rows read out.
    bool readsRow(std::uint64_t field, int y) const noexcept;
    std::int64_t applyRow(const float* e, float* counts, std::uint16_t* video,
                          int w) const noexcept;
    // The droop alone (VideoParams::streak_fraction): out[x] = e[x] − f·m[x − 1],
    // m[x] = r·m[x − 1] + (1 − r)·e[x], m[−1] = 0, r = exp(−1/τ). A flat line of level S
    // gives S·(1 − f·(1 − exp(−x/τ))) exactly. out may be e.
    static void droopRow(const float* e, float* out, int w, double fraction,
                         double tau_px) noexcept;

  private:
    float countOf(float s) const noexcept;  // one pixel's conversion
    // countOf over a row; s may be o (the droop's path converts its own output in place).
    std::int64_t countRow(const float* s, float* o, std::uint16_t* v, int w) const noexcept;
    const CameraParams* cam_;
    int maxCount_;
    // Gamma ≠ 1: the output count for a signal is the number of thresholds at or below it,
    // thr_[k] = the signal at which the rounded output reaches k + 1 (exact rounding of
    // span·(s/span)^γ + offset, computed once in double). lut_ starts the search from a
    // uniform grid over [0, span].
    bool gamma_ = false;
    bool oneStep_ = false;  // no grid cell holds two steps
    std::vector<float> thr_;
    std::vector<std::int32_t> lut_;  // 32-bit entries: vector gathers
    float lutScale_ = 0.0f;
};

}  // namespace nvs::sensor
