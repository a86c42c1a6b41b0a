#pragma once
// Step 1, optics (docs/sensor.md): the lens collects the scene's photoelectron radiance onto
// the photocathode, with cos⁴θ fall-off.

#include <cstdint>
#include <vector>

#include "sim/core/image.h"
#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;

enum class SolidAngleModel { Lens, CcdArea };

struct OpticsParams {
    double f_number = 5.6;  // thesis §4.3: collection at f/5.6, wide open
    // --- 1. Optics -----------------------------------------------------------------------
    double focal_length_mm = 36.0;  // thesis §4.3 (Sony 16-64 zoom at ~36 mm)
    double optics_transmission = 0.9;
    bool cos4 = true;
    double optics_fill_factor = 1.0;  // fraction of the pixel footprint that collects
    SolidAngleModel solid_angle = SolidAngleModel::Lens;
    // Veiling glare: the lens's stray light as a uniform veil, the veiling glare index of ISO
    // 9358 (the share of a uniform field's illuminance found in the image of a small black
    // spot): rate' = (1 − g)·rate + g·mean(rate), the total kept. 0 (default): off; a preset
    // states it with its source.
    double veiling_glare_index = 0.0;

    // Reads f_number, [optics] of the preset over the defaults above; errors name
    // file:line or the --set KEY.
    void read(const PresetReader& root);
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
    // Veiling glare (after every row of apply(), apply() does it): the image's mean rate from
    // its total, then each row in place.
    bool veiled() const noexcept { return glare_ > 0.0f; }
    double veilMean(double total) const noexcept { return total / pixels_; }
    void veilRow(float* rate, double mean) const noexcept;

  private:
    float onAxis_;            // pe/s per pixel per unit Lpe on the axis
    float glare_;             // veiling glare index g
    double pixels_;           // width × height
    std::vector<float> dx2_;  // (dx/f)² of each column (0 without cos⁴θ)
    std::vector<float> dy2_;  // (dy/f)² of each row
};

}  // namespace nvs::sensor
