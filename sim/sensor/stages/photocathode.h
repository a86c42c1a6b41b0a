#pragma once
// Step 3, photocathode (docs/sensor.md): photoelectrons, Poisson about (rate + EBI)·gate; and
// the spectral response that converts band radiance into photoelectron radiance.

#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "sim/core/image.h"
#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;

struct PhotocathodeParams {
    // --- Spectral conversion (W/m2/sr inputs only) -----------------------------------------
    std::filesystem::path response_file;  // relative response beta(λ), peak 1
    std::string response_column = "response_rel";
    double qe_peak = 0.25;          // [pe/photon] GaAs "typically 25 %" (thesis §6.2.4)
    double monochromatic_nm = 0.0;  // > 0: thesis eq. 6.25 single-wavelength conversion

    // --- 3. Photocathode -----------------------------------------------------------------
    bool shot_noise = true;
    double ebi_lm_cm2 = 3.5e-11;  // [lm/cm2] equivalent background illumination (Table 11-1)
    double cathode_sensitivity_uA_lm = 1800.0;  // [µA/lm] Gen III GaAs, typical
    double taper_magnification = 1.636;         // cathode/CCD size: 18 mm -> 11 mm (2/3")

    // Reads [spectral], [photocathode] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
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
    // After begin(): this field's photoelectrons (and EBI) scaled by f, the exposure a gate
    // of duty cycle f leaves (bright-source protection on the photoelectron count).
    void scaleExposure(double f) noexcept {
        t_s_ = static_cast<float>(static_cast<double>(t_s_) * f);
    }
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

}  // namespace nvs::sensor
