#pragma once
// Step 6, ADC (docs/bolometer.md): the corrected detector output → 14-bit raw counts.
//
//   name            unit      default  meaning / source
//   bits            1         14       raw output word (datasheets: 14-bit pre-AGC video)
//   counts_per_K    counts/K  50       raw counts per kelvin of scene at reference_K (assumed)
//   reference_K     K         300      scene temperature of counts_per_K and level_counts
//   level_counts    counts    8192     raw level of a reference_K scene (mid-scale)
//
//   raw = clamp(round(level + k·(V − V_ref)), 0, 2^bits − 1),
//   k = counts_per_K / (dV/dT at reference_K), V_ref = R·P(L_band(reference_K)):
// linear in radiance (a bolometer's output is), so counts per kelvin grow with the scene's
// temperature as dL/dT does.

#include <cstdint>

#include "sim/bolometer/stages/stage.h"
#include "sim/core/image.h"

namespace nvs::bolometer {

struct AdcParams {
    int adc_bits = 14;
    double counts_per_K = 50.0;
    double adc_reference_K = 300.0;
    double level_counts = 8192.0;

    void read(const Reader& root);
};

class AdcStage {
  public:
    explicit AdcStage(const ThermalCameraParams& cam);
    // Quantises the volts; returns the number of pixels clipped at 0 or full scale, and the
    // sum of the counts in sum_counts. Rows up to 2^16 pixels.
    std::int64_t apply(ImageView<const float> volts, ImageView<std::uint16_t> raw,
                       double& sum_counts) const noexcept;
    // One row of n pixels: returns the pixels clipped, adds the counts to sum_counts.
    int applyRow(const float* volts, std::uint16_t* raw, int n,
                 std::uint32_t& sum_counts) const noexcept;
    int maxCount() const { return max_; }
    double countsPerVolt() const { return static_cast<double>(k_); }

  private:
    float k_;       // counts per volt
    float offset_;  // level − k·V_ref
    int max_;
};

}  // namespace nvs::bolometer
