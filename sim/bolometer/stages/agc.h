#pragma once
// Step 7, gain control to 8 bit (docs/bolometer.md).
//
//   name             unit  default    meaning / source
//   mode             -     "plateau"  "linear" or "plateau"
//   clip_low         1     0.005      linear: fraction of pixels mapped to 0 (percentile)
//   clip_high        1     0.995      linear: percentile mapped to 255
//   time_constant_s  s     0.5        linear: damping of the clip levels (first-order)
//   plateau_rel      1     0.005      plateau: the plateau, as a fraction of the pixels
//
// Linear: lo, hi = the clip_low and clip_high percentiles of the frame's raw histogram, damped
// frame to frame, lo_k = lo_{k−1} + (1 − e^(−Δt/τ))(lo* − lo_{k−1}) (the same for hi); the
// first frame takes them as they are; out = round(255·(raw − lo)/(hi − lo)), clamped.
// Plateau equalisation (Vickers, "Plateau equalization algorithm for real-time display of
// high-quality infrared imagery", Opt. Eng. 35(7), 1921–1926, 1996): the raw histogram with
// every bin clipped at the plateau P = max(1, round(plateau_rel·pixels)), h'(b) = min(h(b), P),
// its cumulative sum C(b), and out(v) = round(255·(C(v) − C(v_min))/(C(v_max) − C(v_min)))
// with v_min, v_max the lowest and highest occupied bins (a flat image maps to 0). A plateau
// of one pixel count spreads the occupied levels evenly; a plateau above the pixel count is
// plain histogram equalisation.

#include <array>
#include <cstdint>
#include <vector>

#include "sim/bolometer/stages/stage.h"
#include "sim/core/image.h"

namespace nvs::bolometer {

enum class AgcMode { Linear, Plateau };

struct AgcParams {
    AgcMode agc_mode = AgcMode::Plateau;
    double clip_low = 0.005;
    double clip_high = 0.995;
    double agc_time_constant_s = 0.5;
    double plateau_rel = 0.005;

    void read(const Reader& root);
};

class AgcStage {
  public:
    explicit AgcStage(const ThermalCameraParams& cam);
    // Maps the raw frame to 8 bit, with the histogram of this frame.
    void apply(ImageView<const std::uint16_t> raw, ImageView<std::uint8_t> out) noexcept;
    // The levels mapped to 0 and 255 by the last frame (linear), or its lowest and highest
    // occupied bins (plateau).
    double low_counts() const { return lo_; }
    double high_counts() const { return hi_; }

  private:
    void histogram(ImageView<const std::uint16_t> raw) noexcept;
    void linearLut() noexcept;
    void plateauLut() noexcept;
    AgcMode mode_;
    double clipLow_, clipHigh_, alpha_;
    std::uint32_t plateau_;
    std::uint64_t pixels_;
    bool primed_ = false;
    double lo_ = 0.0, hi_ = 0.0;
    std::vector<std::uint32_t> hist_;  // 2^bits bins
    std::vector<std::uint8_t> lut_;
};

}  // namespace nvs::bolometer
