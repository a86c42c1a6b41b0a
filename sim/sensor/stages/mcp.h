#pragma once
// Steps 4, 5 and 5b (docs/sensor.md): bright-source protection, the MCP's electron gain and
// its local saturation.

#include <cstdint>
#include <memory>

#include "sim/core/gamma_table.h"
#include "sim/core/image.h"
#include "sim/sensor/stages/stage.h"

namespace nvs {
class PixelRng;
}

namespace nvs::sensor {

struct CameraParams;

struct McpParams {
    // --- 4. Bright-source protection (agc = "bsp") -------------------------------------------
    double bsp_knee_A = 2e-11;  // [A] cathode current at which gain halves
    double bsp_exponent = 1.0;
    // Where the factor acts: on the MCP's gain (false: a cathode series resistor that lowers
    // the voltage, each photoelectron amplified less) or on the photoelectron count (true, key
    // acts_on = "photoelectrons": a gate whose duty cycle falls, fewer photoelectrons each
    // amplified as before). The mean is the same; the shot noise per DC is not.
    bool bsp_on_photoelectrons = false;

    // --- 5. MCP ---------------------------------------------------------------------------
    // Absolute gain: Vc directly, or (anchor) the tube's luminous gain at a control voltage,
    // from which Vc follows (luminousGain_fL_fc).
    double mcp_crossover_V = 520.0;        // [V] Vc, eq. 6.1 (typical 350-530 V)
    double luminous_gain_fL_fc = 0.0;      // [fL/fc] anchor; 0: crossover_V as given
    double luminous_gain_control_V = 0.0;  // [V] control voltage of that figure
    double mcp_exponent = 10.0;            // g, eq. 6.1 (typical 8.5-13)
    double mcp_offset_V = 40.0;            // [V] Vm = offset + slope·gain_V
    double mcp_V_per_control_V = 190.0;
    // Mean electron gain of a channel that an electron enters: eq. 6.1's law, bounded above by
    // the plate's saturation (space charge in the channel, the supply's limit): G_ch = x/(1 +
    // x/G_max), x = (Vm/Vc)^g; 0: no bound.
    double mcp_gain_max = 0.0;
    // The supply's ceiling on the plate voltage [V]: Vm = min(offset + slope·gain_V, this); above
    // the control voltage that reaches it the gain no longer rises. 0: no ceiling.
    double mcp_plate_max_V = 0.0;
    // Share of photoelectrons that start a channel (open-area ratio, ion-barrier film): the
    // MCP's output per photoelectron is η·G_ch; F below is per photoelectron, η's loss included.
    double mcp_detection_efficiency = 1.0;
    double mcp_noise_factor = 1.6;  // F, excess noise factor
    bool mcp_noise = true;
    bool mcp_enabled = true;

    // --- 5b. MCP local saturation: the charge a channel can give, recharged through its wall -
    bool mcpsat_enabled = false;
    double mcpsat_pixel_charge_e = 2.4e4;  // output electrons available per CCD-pixel area
    double mcpsat_recharge_s = 0.01;       // recharge time constant τ

    // The plate voltage at a control voltage, under the supply's ceiling.
    double plateVoltage_V(double gainControl_V) const;
    // A channel's electron gain at a control voltage: eq. 6.1, G = (Vm/Vc)^g, Vm = offset +
    // slope·gain_V up to plate_max_V, under the ceiling mcp_gain_max.
    double mcpChannelGain(double gainControl_V) const;
    // MCP output electrons per photoelectron: η·G_ch.
    double mcpGain(double gainControl_V) const;
    // Inverse of mcpGain (for the AGC loop) by the law without the plate's ceiling, so a loop
    // asking for more than the ceiling's gain winds up to its own limit, as a real loop's
    // integrator does; a gain at or past mcp_gain_max gives the voltage of 0.999 of it.
    double controlVoltageForGain(double gain) const;
    // The crossover voltage Vc that gives `gain` electrons per photoelectron at gainControl_V.
    double crossoverForGain(double gain, double gainControl_V) const;

    // Reads [bsp], [mcp], [mcp_saturation] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
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
    void drawPastTable(const float* v, float* e, int m, const int* idx, const PixelRng& rng,
                       std::uint32_t yy, double theta, std::size_t off) noexcept;
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

}  // namespace nvs::sensor
