#pragma once
// Step 8, CCD (docs/sensor.md): fixed pattern, dark charge, full well, blooming, smear and
// read noise.

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <memory>

#include "sim/core/image.h"
#include "sim/core/rng.h"
#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;

enum class BloomDirection { Off, Vertical, Horizontal };

// How the CCD is built, from its datasheet (docs/sensor.md, step 8). An interline CCD has a
// vertical overflow drain under each photodiode: charge above full well flows into the
// substrate (up to the drain's overload capacity) instead of into its neighbours, and its
// shielded vertical registers see a little stray light while they are clocked (smear). Frame
// transfer and full-frame CCDs have no drain here: an overload blooms along `bloom`.
enum class CcdArchitecture { Interline, FrameTransfer, FullFrame };

struct CcdParams {
    // --- 8. CCD ---------------------------------------------------------------------------
    double pitch_x_um = 11.0;  // Table 11-2, cell 11 x 13 µm
    double pitch_y_um = 13.0;
    double full_well_e = 60000.0;  // [e] 0 = unlimited
    CcdArchitecture architecture = CcdArchitecture::FullFrame;
    BloomDirection bloom = BloomDirection::Vertical;  // frame transfer / full frame only
    // Interline: the overflow drain takes charge up to overload_x·full_well_e in a cell; only
    // what exceeds that spills into the vertical register (blooms along the column).
    double overload_x = 1000.0;
    double smear_rel = 0.0;  // fraction of a column's mean (undrained) charge added to its cells
    // Interline: smear_dB, the datasheet's smear ratio by the 1/10 V method (a bright area of
    // 1/10 of the height): smear / signal = 10^(dB/20); smear_rel = 10·10^(smear_dB/20).
    static double smearRelFromDb(double smear_dB) { return 10.0 * std::pow(10.0, smear_dB / 20.0); }
    double dark_e_s = 0.0;      // [e/s] CCD dark current
    double read_noise_e = 0.0;  // [e rms]
    double prnu_rel = 0.0;      // fixed-pattern gain non-uniformity, rms fraction
    // A second fixed gain pattern that varies in blotches rather than cell by cell (uneven
    // activation of a photocathode, a fibre-optic bundle's multifibres): white noise low-passed
    // by a Gaussian of prnu_blotch_sigma_px, scaled to zero mean and prnu_blotch_rel rms. Its
    // autocorrelation is exp(−r²/4σ²) (docs/sensor.md, stage 8).
    double prnu_blotch_rel = 0.0;       // rms fraction
    double prnu_blotch_sigma_px = 0.0;  // [px] the low-pass Gaussian's σ, in CCD cells

    // Reads [ccd] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
};

// ---- 8. CCD ---------------------------------------------------------------------------------
class CcdStage {
  public:
    CcdStage(const CameraParams& cam, std::uint64_t seed);
    // Returns the number of cells that reached full well.
    std::int64_t apply(ImageView<float> e, const FieldContext& ctx) noexcept;
    // apply() in steps: begin(); loadRow(src, e.row(y), y) for every row in order (src may be
    // the row itself; charge below zero counts as none); bloom(e) (returns cells at full well);
    // then finishRow(e.row(y), y) for every row (smear, and read noise on the rows read out).
    void begin(const FieldContext& ctx) noexcept;
    void loadRow(const float* src, float* dst, int y) noexcept;
    // loadRow in two steps, for bands of rows at once: beginLoad(); loadRowMax(src, dst, y,
    // slot) for every row (src ≠ dst; any order, the slot's own column maxima); then
    // finishLoad(dst) merges the maxima, forms the column sums and makes the blooming down
    // sweep, rows in order: the same values as loadRow row by row.
    void beginLoad() noexcept;
    void loadRowMax(const float* src, float* dst, int y, int slot) noexcept;
    void finishLoad(ImageView<float> e) noexcept;
    std::int64_t bloom(ImageView<float> e) noexcept;
    void finishRow(float* v, int y, int slot = 0) noexcept;
    // Thesis Appendix L, charge-conserving form: excess over full well in one line spills
    // half each way along the line, filling neighbours to full well before passing on; what
    // leaves the ends is drained. Exposed for tests. Returns cells at full well.
    static std::int64_t bloomLine(float* v, int n, std::ptrdiff_t step, float fullWell,
                                  float* carryBuf) noexcept;

  private:
    // Setup: the blotch pattern (CcdParams::prnu_blotch_rel) multiplied into prnu_.
    void multiplyBlotches(const CameraParams& cam, const PixelRng& rng);
    // Interline: the overflow drain on one loaded row (charge above full well leaves, up to
    // the overload capacity).
    void drainRow(float* v) const noexcept;
    std::int64_t bloomColumns(ImageView<float> e, float fw, const float* colMax,
                              float* colSum) noexcept;
    const CameraParams* cam_;
    std::uint64_t seed_;
    // This field (begin()).
    std::uint64_t field_ = 0;
    float dark_e_ = 0.0f;
    float sigma_e_ = 0.0f;
    int readY0_ = 0, readDy_ = 1;
    ImageF upCarry_;                 // vertical blooming: charge bound up the column
    ImageF prnu_;                    // 1 + fixed-pattern gain deviation, empty if off
    std::unique_ptr<float[]> line_;  // scratch for blooming (max(w, h) floats)
    std::unique_ptr<float[]> colSum_;
    std::unique_ptr<float[]> colMax_;
    std::unique_ptr<float[]> slotMax_;        // loadRowMax: the column maxima of each slot
    std::size_t stride_;                      // one slot's row scratch
    std::unique_ptr<std::uint32_t[]> words_;  // one row of words per slot
    std::unique_ptr<float[]> z_;              // one row of normals per slot
    std::unique_ptr<float[]> row_;            // in-place loadRow(): a copy of the row
    double noiseSigma_e_;  // read noise ⊕ video pre-amplifier noise referred to electrons
};

}  // namespace nvs::sensor
