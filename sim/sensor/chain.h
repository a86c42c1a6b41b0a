#pragma once
// The IICCD chain (docs/design.md §4.5): photoelectron radiance at the lens → digital counts, one
// field (or frame) per call, with state carried between calls (phosphor afterglow, the AGC /
// ABC / auto-gate loop, the interlaced output frame).
//
// Two phases. The constructor validates the preset, builds every stage and allocates every
// buffer (FFTW plans included). process() allocates nothing and throws nothing; it is noexcept.
// Randomness comes only from PixelRng (sim/core/rng.h) keyed by (seed, stream, field): pixel
// (x, y) draws its words x·W … x·W+W−1 of row y (W words per pixel per plane) and, if a
// sampler needs more, its own pixel stream. So the noise of a pixel is a pure function of
// (seed, stream, field, x, y) and of its own mean: identical under any threading or tiling.
//
// Stage order, each a class below, each skipped entirely when the preset turns it off:
//   1 Optics  2 Gate  3 Photocathode  4 BSP  5 MCP (+ABC)  6 Phosphor  7 Blur (MTF)
//   8 CCD (FPN, dark, full well, blooming, smear, read noise)  9 Video (gain, offset, gamma,
//   interlace, ADC)  10 AGC loop (one-field lag, time constant, limits).
//
// Each stage's whole-image apply() is made of its row operations (applyRow …), and
// IiccdChain::process runs the same row operations interleaved: optics → photocathode → MCP →
// phosphor row by row straight into the blur's FFT buffer, then CCD → video row by row. The
// two orders give the same bits (each row operation depends only on its row and the per-field
// constants), so a caller composing the stages one by one matches IiccdChain exactly.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "sim/core/gamma_table.h"
#include "sim/core/image.h"
#include "sim/core/row_executor.h"
#include "sim/sensor/camera.h"

namespace nvs::sensor {

// Row scratch is rounded up to whole Philox blocks and vector chunks.
inline constexpr int kRowPad_px = 32;
// The chain splits a field into this many bands of rows, whatever the number of threads that
// run them: each band has its own row scratch in every stage (its slot), and no result depends
// on which thread ran a band or in what order. Sixteen, so that a thread that finishes its last
// band early waits for at most a sixteenth of a pass (and a thread held up by the machine holds
// back that much).
inline constexpr int kChainSlots = 16;
// The blur's column FFTs run in this many bands of spectrum columns (their FFTW plans, and so
// the shipped wisdom, are made for that band width).
inline constexpr int kBlurColumnBands = 8;

// What one call did: the state of the controls and the observables a driver reports.
struct FieldInfo {
    std::uint64_t field = 0;
    double t_sample_s = 0.0;  // mid-exposure time of this field since the first
    double gain_V = 0.0;      // tube gain control voltage applied
    double mcp_gain = 0.0;    // electron gain applied (BSP included)
    double gate_s = 0.0;      // exposure
    double bsp_factor = 1.0;  // gain factor from bright-source protection
    double cathode_current_A = 0.0;
    double screen_current_A = 0.0;
    double mean_pe = 0.0;           // mean photoelectrons per pixel
    double level_dc = 0.0;          // mean output of this field's rows
    std::int64_t saturated_px = 0;  // cells that reached full well
    std::int64_t bad_input_px = 0;  // NaN, infinite or negative input (treated as 0)
    bool size_mismatch = false;     // input not width × height: nothing was computed
};

struct ChainOptions {
    bool measureFft = false;  // FFTW_MEASURE plans (slower setup, faster fields)
    bool patientFft = false;  // FFTW_PATIENT plans (what the shipped wisdom is made with)
};

// Per-field values the stages hand to each other.
struct FieldContext {
    std::uint64_t field = 0;
    double period_s = 0.0;
    double gate_s = 0.0;
    double gain_V = 0.0;
    double mcpGain = 1.0;
    double cathodeRate_pe_s = 0.0;  // expected, whole cathode
    double mcpOut_e = 0.0;          // MCP output electrons, whole screen
};

// ---- 1. Optics ------------------------------------------------------------------------------
class OpticsStage {
  public:
    explicit OpticsStage(const CameraParams& cam);
    // rate = Lpe·τ·π/(4N²)·A·cos⁴θ [pe/s per pixel]. Returns the number of bad input pixels;
    // adds the expected total rate to ctx.cathodeRate_pe_s.
    std::int64_t apply(ImageView<const float> lpe, ImageView<float> rate,
                       FieldContext& ctx) const noexcept;
    // Row y of apply(): returns the bad pixels; rowSum = the row's expected rate.
    int applyRow(const float* lpe, float* rate, int y, double& rowSum) const noexcept;

  private:
    float onAxis_;            // pe/s per pixel per unit Lpe on the axis
    std::vector<float> dx2_;  // (dx/f)² of each column (0 without cos⁴θ)
    std::vector<float> dy2_;  // (dy/f)² of each row
};

// ---- 2. Gate --------------------------------------------------------------------------------
class GateStage {
  public:
    explicit GateStage(const CameraParams& cam);
    // Exposure for this field: the preset gate, scaled by the auto-gate loop.
    double gate_s(double period_s, double autogateScale) const noexcept;

  private:
    double gate_s_;
    double min_s_;
};

// ---- 3. Photocathode ------------------------------------------------------------------------
class PhotocathodeStage {
  public:
    PhotocathodeStage(const CameraParams& cam, std::uint64_t seed);
    // pe = Poisson((rate + ebi)·t_gate), or its mean when shot noise is off.
    void apply(ImageView<const float> rate, ImageView<float> pe, FieldContext& ctx) noexcept;
    double ebiRate_pe_s() const { return ebi_pe_s_; }
    // apply() by rows: begin() adds the EBI to ctx.cathodeRate_pe_s and fixes the field's
    // exposure and noise key; applyRow() then draws row y.
    // `slot` (0 … kChainSlots − 1): whose row scratch; rows in different slots may run at once.
    void begin(FieldContext& ctx, int w, int h) noexcept;
    void applyRow(const float* rate, float* pe, int w, int y, int slot = 0) noexcept;

  private:
    bool noise_;
    double ebi_pe_s_;  // per pixel
    std::uint64_t seed_;
    std::uint64_t field_ = 0;
    float t_s_ = 0.0f;                        // this field's gate
    std::size_t stride_;                      // one slot's row scratch
    std::unique_ptr<float[]> mean_;           // one row of means per slot
    std::unique_ptr<std::uint32_t[]> words_;  // one row of words per slot
};

// ---- 3b. Halo ------------------------------------------------------------------------------
// Photoelectrons that strike the MCP's web between channels scatter back elastically, with the
// energy e·V the cathode–MCP field gave them, and the same field turns them round: launched at
// θ from the normal they land r = 2d·sin 2θ away (d the gap), whatever V is. So a share f of the
// photoelectrons land on a disk of radius R = 2d, densest at its rim (r = R·sin 2θ over
// cosine-law launches: p(r) ∝ 1/√(1 − (r/R)²)). Applied to the expected photocathode rate
// (displacing a Poisson process's points keeps it Poisson), on a grid of kBlock-pixel cells:
// the disk spans tens of pixels and its sum is smooth at that scale.
class HaloStage {
  public:
    static constexpr int kBlock = 4;
    explicit HaloStage(const CameraParams& cam);
    bool enabled() const { return enabled_; }
    // rate ← (1 − f)·rate + f·(rate ⊛ disk), in place; conserves the total. By bands of rows
    // through `exec` (the same bits with any executor).
    void apply(ImageView<float> rate) noexcept;
    void apply(ImageView<float> rate, RowExecutor& exec) noexcept;
    // apply() in its steps, for callers that fuse them with their own row passes: sumCells()
    // for every band of cell rows [cy0, cy1) (after the kBlock pixel rows of each are
    // written), then spread(exec), then addBackRow(rate row y, y) for every pixel row.
    int cellRows() const { return ch_; }
    void sumCells(ImageView<const float> rate, int cy0, int cy1) noexcept;
    void spread(RowExecutor& exec) noexcept;
    void addBackRow(float* rateRow, int y) noexcept;
    // The same into `out` (another row of the image's width; rateRow is only read).
    void addBackRow(const float* rateRow, float* out, int y) noexcept;
    // The kernel on the cell grid (odd size, sums to 1), for tests.
    const std::vector<float>& kernel() const { return kernel_; }
    int kernelRadiusCells() const { return kr_; }

  private:
    bool enabled_;
    float fraction_ = 0.0f;
    int w_ = 0, h_ = 0, cw_ = 0, ch_ = 0, kr_ = 0;
    std::vector<float> kernel_;  // (2kr+1)² weights
    ImageF cells_;               // rate summed over each cell
    ImageF spread_;              // cells convolved with the disk, per pixel of a cell
};

// ---- 4. Bright-source protection ------------------------------------------------------------
class BspStage {
  public:
    explicit BspStage(const CameraParams& cam);
    bool enabled() const { return enabled_; }
    // Gain factor for a cathode current: 1/(1 + (I/I_knee)^p).
    double factor(double cathodeCurrent_A) const noexcept;

  private:
    bool enabled_;
    double knee_A_;
    double exponent_;
};

// ---- 5. MCP ---------------------------------------------------------------------------------
class McpStage {
  public:
    // The Gamma tables come from `gammaTables` (shared with the other chains made with it).
    McpStage(const CameraParams& cam, std::uint64_t seed, GammaTableCache& gammaTables);
    bool enabled() const { return enabled_; }
    // electrons = Σ of N single-electron gains ~ Gamma(N·k, G/k), k = 1/(F − 1).
    void apply(ImageView<float> pe, FieldContext& ctx) noexcept;
    // apply() by rows: begin() fixes the gain (ctx.mcpGain) and noise key, applyRow()
    // multiplies row y in place and returns its sum of electrons (`slot`: whose scratch, as in
    // PhotocathodeStage; `sum` false: the sum is not wanted and 0 is returned, unless the MCP
    // is noise-free).
    void begin(const FieldContext& ctx) noexcept;
    double applyRow(float* pe, int w, int y, int slot = 0, bool sum = true) noexcept;

  private:
    bool enabled_;
    bool noise_;
    double k_;  // 1/(F − 1)
    std::uint64_t seed_;
    std::uint64_t field_ = 0;
    double gain_ = 1.0;
    std::shared_ptr<const GammaTable> table_;  // quantiles of Gamma(N·k), N ≤ kMaxN
    // Row scratch, kChainSlots rows of stride_ each (heads_: 4·stride_ per slot).
    std::size_t stride_;
    std::unique_ptr<std::uint32_t[]> words_;   // one row of words, one per pixel
    std::unique_ptr<int[]> idx_;               // pixels of the row that draw
    std::unique_ptr<std::uint32_t[]> blocks_;  // their Philox blocks / stream x
    std::unique_ptr<std::uint32_t[]> uWords_;  // their words
    std::unique_ptr<float[]> n_;               // their photoelectrons
    std::unique_ptr<float[]> e_;               // their electrons (−1: not drawn yet)
    std::unique_ptr<int[]> rest_;              // drawers past the table
    std::unique_ptr<float[]> restN_;           // their photoelectrons
    std::unique_ptr<std::uint32_t[]> heads_;   // their stream heads (or listed row blocks)
    std::unique_ptr<float[]> z_;               // normals of their first head words
    std::unique_ptr<double[]> g_;              // their first Marsaglia–Tsang attempts
};

// ---- 5b. MCP local saturation ----------------------------------------------------------------
// A channel gives its charge from the wall and recharges through the plate's resistance: the
// electrons an area can put out in a field are bounded by the charge it holds, Q ≤ Q_max
// (pixel_charge_e per CCD pixel area), and what it gave returns with the time constant τ. Per
// pixel: asked for D electrons (the MCP's linear output), it gives Q·(1 − e^(−D/Q)) — D when
// D ≪ Q, Q at most — and then holds Q_max − (Q_max − Q + out)·e^(−T/τ) for the next field. So a
// lamp saturates a disk of the size of its image (its halo included), and the depletion it
// leaves fades over τ, across fields.
class McpSaturationStage {
  public:
    explicit McpSaturationStage(const CameraParams& cam);
    bool enabled() const { return enabled_; }
    void begin(const FieldContext& ctx) noexcept;  // this period's recharge factor
    // Row y of MCP output electrons, in place; returns the row's sum after saturation.
    double applyRow(float* e, int w, int y) noexcept;
    void reset() noexcept;
    const ImageF& charge() const { return q_; }  // available charge per pixel [e]

  private:
    bool enabled_;
    double tau_s_;
    float qMax_ = 0.0f;
    float keep_ = 0.0f;  // e^(−T/τ)
    ImageF q_;
};

// ---- 6. Phosphor ----------------------------------------------------------------------------
class PhosphorStage {
  public:
    explicit PhosphorStage(const CameraParams& cam);
    // Light collected by the CCD in this period [CCD electrons] from the electrons deposited
    // in it and the afterglow stored from earlier ones. Carries the stored energy.
    void apply(ImageView<float> signal, const FieldContext& ctx) noexcept;
    void reset() noexcept;
    bool enabled() const { return enabled_; }
    // apply() by rows: begin() fixes this field's coefficients, applyRow() converts row y of
    // MCP electrons `in` into CCD electrons `out` (distinct rows) and updates the state.
    void begin(const FieldContext& ctx) noexcept;
    void applyRow(const float* in, float* out, int w, int y) noexcept;
    // The input is never above maxIn (MCP electrons a pixel and period: IiccdChain passes MCP
    // saturation's channel charge): the stored afterglow is then bounded, and is kept from here
    // on in binary16 times a power-of-two scale per component, the scale putting the store's
    // bound at 2^14 (half the memory stream of float stores, read and written every period).
    // Error of a store: 2^−12 relative, and below 2^−27 of the bound (the subnormal halves) at
    // most 2^−38 of the bound absolute (PULNiX: 3e-6 CCD electrons). Setup only; resets the store.
    void boundInput(double maxIn);
    // Fraction of an excitation spread over a gate of length g at the start of a period T
    // that component τ emits within that period (docs/sensor.md, step 6).
    static double inPeriodFraction(double tau_s, double gate_s, double period_s);

  private:
    bool enabled_;
    double eta_;  // CCD electrons per MCP electron, eq. 6.2
    int n_ = 0;
    double tau_s_[4] = {};
    double weight_[4] = {};
    bool stored_[4] = {};  // components whose afterglow outlives a period
    // Stored energy of the stored components, in CCD electrons: row y holds the row's pixels
    // in blocks of 16, each block the 16 values of the first stored component, then of the
    // second, … (one memory stream for the per-pixel loop).
    ImageF state_;
    // The same in binary16 after boundInput() (state_ then empty), each component's values
    // times invScale_ (powers of two).
    ImageU16 half_;
    float scale_[4] = {1.0f, 1.0f, 1.0f, 1.0f};
    float invScale_[4] = {1.0f, 1.0f, 1.0f, 1.0f};
    double period_s_ = 0.0;
    // This field's coefficients (begin()): m_ stored components idx_[], each keeping
    // keepEta_ of the excitation, decaying by decay_ and emitting emit_ of its store; nowEta_
    // of the excitation is emitted at once.
    int m_ = 0;
    int idx_[4] = {};
    float nowEta_ = 0.0f;
    float keepEta_[4] = {};
    float decay_[4] = {};
    float emit_[4] = {};
    std::unique_ptr<float[]> row_;  // in-place apply(): a copy of the row
};

// The phosphor's rows with a binary16 store (PhosphorStage::boundInput): the portable form and
// the AVX-512 one (hardware conversions), the same bits; exposed for the test that checks so.
// w pixels in blocks of 16, m stored components, the store of a block as PhosphorStage::state_.
namespace detail {
void phosphorRowHalf(const float* in, float* out, std::uint16_t* st, int w, int m, float nowEta,
                     const float* k, const float* dc, const float* em, const float* scale,
                     const float* inv) noexcept;
void phosphorRowHalfAvx512(const float* in, float* out, std::uint16_t* st, int w, int m,
                           float nowEta, const float* k, const float* dc, const float* em,
                           const float* scale, const float* inv) noexcept;
bool phosphorHasAvx512() noexcept;  // false where phosphorRowHalfAvx512 is not built or runnable
}  // namespace detail

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

  private:
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

// ---- 10. AGC loop ---------------------------------------------------------------------------
class AgcLoop {
  public:
    explicit AgcLoop(const CameraParams& cam);
    double gain_V(std::uint64_t field) const noexcept { return gainRing_[field % kRing]; }
    double gateScale(std::uint64_t field) const noexcept { return gateRing_[field % kRing]; }
    // After field k: measure and command field k + lag.
    void update(const FieldContext& ctx, double level_dc) noexcept;
    void reset() noexcept;
    // Starts the loop from a tube gain (the one in effect when it is switched on).
    void start(double gain_V) noexcept;

  private:
    static constexpr int kRing = 8;
    const CameraParams* cam_;
    double gainRing_[kRing];
    double gateRing_[kRing];
    double gainCmd_V_;
    double gateCmd_;
};

// ---- Controls -------------------------------------------------------------------------------
// The camera's controls as commanded for one field by its operator (telemetry, a scenario's
// platform and timeline): the thesis camera's front-panel switches.
struct CameraCommand {
    double gain_V = 0.0;  // manual tube gain control voltage [V]
    double gate_s = 0.0;  // gate width [s] when gated (0: the preset's gate)
    int gateMode = 0;     // 0 continuous, 1 gated, 2 auto-gated
    bool agc = false;     // the camera's automatic loop switched on
};

// Who sets the controls.
//   Preset   the preset alone: manual gain_V and gate, or its own agc loop (agc, abc, bsp,
//            autogate); commands are ignored.
//   Command  each field's CameraCommand:
//              agc = false   manual: gain_V, clamped to [0, agc_max_gain_V]
//              agc = true    the preset's automatic loop (agc, abc, bsp or autogate); a preset
//                            whose agc is "off" runs the plain AGC loop (the camera's AGC
//                            switch turned on); bsp / autogate keep the tube gain at the
//                            preset's gain_V
//              gate          automatic (the autogate loop's scale on the preset gate) when the
//                            preset's loop is autogate and either agc or gateMode = 2;
//                            otherwise by gateMode: 0 continuous (the photocathode is on for
//                            the whole field), 1 or 2 gated at gate_s, clamped to
//                            [gate_min_s, field] (gate_s = 0 keeps the preset's gate)
enum class ControlSource { Preset, Command };

// ---- The chain ------------------------------------------------------------------------------
class IiccdChain {
  public:
    // configDir: the shipped data (FFTW wisdom); gammaTables: the MCP's Gamma tables, shared
    // with the other chains made with the same cache; controls: who sets gain and gate.
    IiccdChain(const CameraParams& cam, std::uint64_t seed, const std::filesystem::path& configDir,
               GammaTableCache& gammaTables, ChainOptions opt = {},
               ControlSource controls = ControlSource::Preset);
    ~IiccdChain();
    IiccdChain(const IiccdChain&) = delete;
    IiccdChain& operator=(const IiccdChain&) = delete;

    // One field (scan = field) or frame (scan = frame). Lpe in pe s⁻¹ m⁻² sr⁻¹, width ×
    // height. Never throws, never allocates; a size mismatch or bad pixels are reported in
    // the returned info.
    const FieldInfo& process(ImageView<const float> lpe) noexcept;
    // The same with this field's commanded controls (used with ControlSource::Command; the
    // preset's own settings otherwise) and the field's mid-exposure time on the caller's clock.
    const FieldInfo& process(ImageView<const float> lpe, const CameraCommand& cmd,
                             double t_sample_s) noexcept;

    // The output frame: integer counts as float, and as uint16 (≤ 2^adc_bits − 1).
    const ImageF& counts() const { return counts_; }
    const ImageU16& video() const { return video_; }
    // Intermediate signal after the last stage before video [CCD electrons] (for tests).
    const ImageF& electrons() const { return sig_; }
    const CameraParams& camera() const { return cam_; }
    std::uint64_t fieldIndex() const { return field_; }
    // What the last call did.
    const FieldInfo& lastInfo() const { return info_; }

    // Who runs the bands of a field (kChainSlots of them): any executor gives the same bits.
    // nullptr: the calling thread alone (the default). The executor must outlive the chain's
    // use of it.
    void setExecutor(RowExecutor* exec) noexcept;

    // Counts how many non-finite or negative pixels an input has (setup-time validation).
    static std::int64_t countBadPixels(ImageView<const float> img);

  private:
    // This field's gain, gate and the loop that measures it (step 10's policy, above).
    struct Controls {
        double gain_V = 0.0;
        double gate_s = 0.0;
        AgcLoop* loop = nullptr;
    };
    Controls controlsFor(const CameraCommand& cmd, double period_s) noexcept;
    // Steps 1–6 row by row into the blur's input, then readOut(): 7–9.
    void run(ImageView<const float> lpe, FieldContext& ctx) noexcept;
    void readOut(const FieldContext& ctx) noexcept;
    // The optics' bad pixels and rate of every row, added up in row order.
    void addOpticsSums(FieldContext& ctx) noexcept;

    CameraParams cam_;
    CameraParams camAuto_;  // cam_ with its automatic loop switched on (ControlSource::Command)
    // Command: the gain applied to the last field, and whether agcAuto_ ran for it (a loop
    // switched on starts from the gain in effect, not from the preset's).
    double lastGain_V_ = 0.0;
    bool autoRunning_ = false;
    ControlSource source_;
    std::uint64_t field_ = 0;
    OpticsStage optics_;
    GateStage gate_;
    PhotocathodeStage cathode_;
    HaloStage halo_;
    BspStage bsp_;
    McpStage mcp_;
    McpSaturationStage mcpSat_;
    PhosphorStage phosphor_;
    BlurStage blur_;
    CcdStage ccd_;
    VideoStage videoStage_;
    AgcLoop agc_;      // the preset's own loop
    AgcLoop agcAuto_;  // the loop a command's agc switch turns on
    ImageF rate_;
    ImageF sig_;
    ImageF counts_;
    ImageU16 video_;
    std::unique_ptr<float[]> rowRate_;  // one row of optics output per slot
    std::unique_ptr<float[]> rowSig_;   // one row of photoelectrons / MCP electrons per slot
    // Per-row results of the bands, added up in row order.
    std::vector<double> rowOptics_;       // expected rate
    std::vector<double> rowMcp_;          // MCP output electrons
    std::vector<int> rowBad_;             // bad input pixels
    std::vector<std::int64_t> rowLevel_;  // sum of output counts; −1: not read out
    SerialExecutor serial_;
    RowExecutor* exec_ = &serial_;
    FieldInfo info_;
};

}  // namespace nvs::sensor
