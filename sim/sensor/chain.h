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
// Stage order, each a class in sim/sensor/stages/ (control.h for step 10), each skipped
// entirely when the preset turns it off:
//   1 Optics  2 Gate  3 Photocathode  4 BSP  5 MCP (+ABC)  6 Phosphor  7 Blur (MTF)
//   8 CCD (FPN, dark, full well, blooming, smear, read noise)  9 Video (gain, offset, gamma,
//   interlace, ADC)  10 AGC loop (one-field lag, time constant, limits).
//
// Each stage's whole-image apply() is made of its row operations (applyRow …), and
// IiccdChain::process runs the same row operations interleaved: optics → photocathode → MCP →
// phosphor row by row straight into the blur's FFT buffer, then CCD → video row by row. The
// two orders give the same bits (each row operation depends only on its row and the per-field
// constants), so a caller composing the stages one by one matches IiccdChain exactly
// (tests/sim/sensor/stages_compose_test.cpp runs both on the same fields and compares the bits).

#include <cstdint>
#include <filesystem>
#include <memory>
#include <vector>

#include "sim/core/gamma_table.h"
#include "sim/core/image.h"
#include "sim/core/row_executor.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/control.h"
#include "sim/sensor/stages/blur.h"
#include "sim/sensor/stages/ccd.h"
#include "sim/sensor/stages/gate.h"
#include "sim/sensor/stages/halo.h"
#include "sim/sensor/stages/mcp.h"
#include "sim/sensor/stages/optics.h"
#include "sim/sensor/stages/phosphor.h"
#include "sim/sensor/stages/photocathode.h"
#include "sim/sensor/stages/stage.h"
#include "sim/sensor/stages/video.h"

namespace nvs::sensor {

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
    // Steps 1–6 row by row into the blur's input, then readOut(): 7–9.
    void run(ImageView<const float> lpe, FieldContext& ctx) noexcept;
    void readOut(const FieldContext& ctx) noexcept;
    void opticsPass(ImageView<const float> lpe, FieldContext& ctx) noexcept;
    // The optics' bad pixels and rate of every row, added up in row order (returns the rate).
    double addOpticsSums(FieldContext& ctx) noexcept;

    CameraParams cam_;
    GainControl control_;  // step 10: each field's gain and gate (sim/sensor/control.h)
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
