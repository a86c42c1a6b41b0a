#pragma once
// Step 6, phosphor (docs/sensor.md): MCP electrons → CCD electrons, with the screen's
// afterglow carried between fields (in binary16 when its input is bounded).

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/core/image.h"
#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;

struct PhosphorParams {
    // --- 6. Phosphor ----------------------------------------------------------------------
    bool phosphor_enabled = true;
    std::string phosphor_type = "P20";
    std::vector<double> phosphor_decay_s = {1e-4, 2e-3, 0.05};
    std::vector<double> phosphor_weight = {0.9, 0.09, 0.01};
    double screen_voltage_V = 6000.0;        // Va, thesis §6.2
    double screen_dead_voltage_V = 1500.0;   // Vd, eq. 6.2
    double phosphor_photons_per_eV = 0.065;  // P, eq. 6.2
    double phosphor_peak_nm = 545.0;         // emission peak (P20)
    double phosphor_efficacy_lm_W = 500.0;   // luminous efficacy of the screen's emission
    double taper_transmission = 0.3;         // T_fot, eq. 6.2
    double ccd_window_transmission = 1.0;    // T_CCD, eq. 6.2
    double ccd_qe = 0.35;                    // QE_CCD at the P20 peak, eq. 6.2
    double ccd_fill_factor = 1.0;            // light-collecting fraction of a CCD cell

    // CCD electrons per MCP output electron, eq. 6.2/6.3.
    double ccdElectronsPerMcpElectron() const;
    // Luminous flux out of the screen per watt of electron beam reaching it [lm/W]:
    // P·(hc/λ_peak)/e photons' energy per eV of beam, times the emission's efficacy.
    double screenLumensPerBeamWatt() const;

    // Reads [phosphor] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
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

}  // namespace nvs::sensor
