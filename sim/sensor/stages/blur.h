#pragma once
// Step 7, blur (docs/sensor.md): the MTF of tube, fibre taper, CCD aperture and digitiser,
// applied by FFT (FFTW, planned from the shipped wisdom).

#include <cstdint>
#include <filesystem>
#include <memory>

#include "sim/core/image.h"
#include "sim/core/row_executor.h"
#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;

struct BlurParams {
    // --- 7. MTF (frequencies in the image plane = photocathode plane) ----------------------
    bool mtf_enabled = true;
    double ii_fc_cyc_mm = 13.75;  // ξc of exp(-(ξ/ξc)^n), eq. 6.14
    double ii_index = 1.18;       // n
    double fibre_pitch_um = 6.0;  // thesis §7.4.1 (0 = no fibre MTF)
    bool ccd_aperture_mtf = true;
    double digitiser_fc_cyc_mm = 0.0;  // 0 = no digitiser stage
    double digitiser_index = 1.0;

    // Reads [mtf] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
};

// The blur's column FFTs run in this many bands of spectrum columns (their FFTW plans, and so
// the shipped wisdom, are made for that band width).
inline constexpr int kBlurColumnBands = 8;

struct ChainOptions {
    bool measureFft = false;  // FFTW_MEASURE plans (slower setup, faster fields)
    bool patientFft = false;  // FFTW_PATIENT plans (what the shipped wisdom is made with)
};

// ---- 7. Blur (MTF) --------------------------------------------------------------------------
class BlurStage {
  public:
    // Plans the FFTs with the wisdom in <configDir>/fftw/wisdom-single.txt where it applies.
    BlurStage(const CameraParams& cam, const ChainOptions& opt,
              const std::filesystem::path& configDir);
    ~BlurStage();
    BlurStage(const BlurStage&) = delete;
    BlurStage& operator=(const BlurStage&) = delete;
    bool enabled() const { return enabled_; }
    void apply(ImageView<float> img) noexcept;
    int paddedWidth() const { return wp_; }
    int paddedHeight() const { return hp_; }
    // apply() in steps: write image row y (w floats) into inputRow(y) for every row, then
    // filter() pads, transforms, applies the MTF and transforms back; outputRow(y) is then the
    // blurred row (ringing below zero not yet removed: the CCD's loadRow clamps it). filter()
    // runs in bands of rows and of columns through `exec` (the same bits with any executor;
    // only the image's rows are transformed back, the padding rows are not).
    float* inputRow(int y) noexcept;
    void filter() noexcept;
    void filter(RowExecutor& exec) noexcept;
    // filter(exec) in its steps, for callers that fuse them with their own row passes:
    // forwardRow(y) for every image row (after inputRow(y) is written; rows in any order or at
    // once), then filterColumns(exec), then inverseRow(y) for every image row (before
    // outputRow(y) is read).
    void forwardRow(int y) noexcept;
    void filterColumns(RowExecutor& exec) noexcept;
    void inverseRow(int y) noexcept;
    // The same steps with the real row in a band's own scratch row (slotRow(slot), paddedWidth()
    // floats) instead of the whole padded image: the row is written, padded and transformed
    // while in cache, and the image-sized real buffer is not streamed through memory. The
    // same plans, alignment and arithmetic, so the same bits. forwardRow pads `row` in place;
    // inverseRow writes the blurred row y into `row`.
    float* slotRow(int slot) noexcept;
    void forwardRow(float* row, int y) noexcept;
    void inverseRow(int y, float* row) noexcept;
    // Writes the wisdom FFTW's planner holds (every plan made so far in this process) to
    // `file` (tests/sim/sensor/fftw_wisdom.cpp makes config/fftw/wisdom-single.txt with it).
    // Returns false if it could not be written.
    static bool exportWisdom(const std::filesystem::path& file);
    const float* outputRow(int y) const noexcept;

  private:
    struct Fft;
    void planTransforms(unsigned flags);
    bool enabled_;
    int w_ = 0, h_ = 0, wp_ = 0, hp_ = 0;
    int wc_ = 0;          // complex columns of the half spectrum, wp/2 + 1
    int wcs_ = 0;         // its row stride (whole 64-byte lines)
    int cb_ = 0;          // columns per column band
    int slotStride_ = 0;  // floats between slot rows (wp_ rounded up to 64-byte lines)
    std::unique_ptr<Fft> fft_;
};

}  // namespace nvs::sensor
