#pragma once
// Step 4, temporal noise (docs/bolometer.md): NETD white noise, row and column noise and 1/f
// noise, in volts at the detector's output, all drawn from Philox keyed by (seed, frame, pixel).
//
//   name              unit  default  meaning / source
//   netd_K            K     0.050    NETD of the core (datasheet), the temporal σ of a pixel
//                                    in scene kelvin: white + row + column noise together
//   netd_reference_K  K     300      scene temperature the NETD is specified at (datasheet)
//   netd_f_number     1     1.0      f-number the NETD is specified at (datasheet)
//   row_rel           1     0.15     σ of the noise common to a row, over NETD's σ (assumed)
//   column_rel        1     0.15     σ of the noise common to a column, over NETD's σ (assumed)
//   flicker_rel       1     0.3      σ of the 1/f noise (stationary), over NETD's σ (assumed)
//   flicker_octaves   1     8        generators of the 1/f noise: 1/f from f/2^(M+1) to f/2
//
// σ = NETD·R·τ·π/(1 + 4N_ref²)·A·FF·dL/dT(T_ref) [V] (the datasheet's NETD is the camera's,
// lens included; through another f-number it scales by (1 + 4N²)/(1 + 4N_ref²)); a pixel's white
// part σ_px = σ·√(1 − row_rel² − column_rel²), so that the three together give NETD's σ (the
// decomposition of D'Agostino & Webb, "3-D analysis framework and measurement methodology for
// imaging system noise", Proc. SPIE 1488, 1991: σ_tvh, σ_tv, σ_th).
// 1/f noise: the Voss–McCartney algorithm (Gardner, "White and brown music, fractal curves
// and one-over-f fluctuations", Scientific American 238(4), 1978, after R. F. Voss), a sum of M
// held generators, generator j redrawn every 2^(j+1) frames (at frames k with ctz(k + 1) = j)
// with a uniform value (Voss's dice; the sum of M is near-normal) of σ_v = flicker_rel·σ/√M, so
// that their sum has σ = flicker_rel·σ (its start: normals): its spectrum falls as 1/f between
// f_frame/2^(M+1) and f_frame/2 (its Allan variance is flat there).

#include <cstdint>
#include <memory>
#include <vector>

#include "sim/bolometer/stages/stage.h"
#include "sim/core/image.h"

namespace nvs::bolometer {

struct NoiseParams {
    double netd_K = 0.050;
    double netd_reference_K = 300.0;
    double netd_f_number = 1.0;
    double row_rel = 0.15;
    double column_rel = 0.15;
    double flicker_rel = 0.3;
    int flicker_octaves = 8;

    void read(const Reader& root);
};

class NoiseStage {
  public:
    NoiseStage(const ThermalCameraParams& cam, std::uint64_t seed);
    // Adds frame k's noise to the volts, in place.
    void apply(ImageView<float> volts, std::uint64_t frame) noexcept;
    // apply() in rows: beginFrame(k) once (the row and column noise, the 1/f generator to
    // redraw), then applyRow for every row.
    void beginFrame(std::uint64_t frame) noexcept;
    void applyRow(int y, float* volts) noexcept;
    double sigmaPixel_V() const { return static_cast<double>(sPx_); }

  private:
    void drawNormals(std::uint64_t frame, std::uint32_t y, std::uint32_t plane, int n) noexcept;
    std::uint64_t seed_;
    int w_, h_;
    float sPx_, sRow_, sCol_, sFlicker_;
    std::vector<std::uint32_t> words_;
    std::vector<float> z_, rowZ_, colZ_;
    std::vector<ImageF> flicker_;  // the M generators
    ImageF flickerSum_;
    std::uint64_t frame_ = 0;  // the frame beginFrame set up
    int redraw_ = -1;          // its 1/f generator to redraw (−1: none)
};

}  // namespace nvs::bolometer
