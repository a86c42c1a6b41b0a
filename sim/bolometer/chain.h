#pragma once
// The uncooled microbolometer camera (docs/bolometer.md): band radiance at the aperture
// [W m⁻² sr⁻¹ in the preset's band] → 14-bit raw counts and 8-bit display, one frame per call,
// with state carried between calls (the pixels' thermal lag, the focal-plane temperature, the
// 1/f noise, the shutter's offset map, the AGC's damped levels).
//
// Two phases, as the intensified chain (sim/sensor/chain.h): the constructor validates and
// allocates everything (FFTW plans too: like FFTW's planner, not thread-safe; chains are made on
// one thread); process() allocates nothing and throws nothing. Randomness comes only
// from PixelRng (sim/core/rng.h) keyed by (seed, stream, frame) and the pixel's place, so a
// replay with the same seed gives the same bits.
//
// Stage order, each a class in sim/bolometer/stages/:
//   1 Optics (lens, MTF)  2 Detector (thermal lag, responsivity)  3 Focal plane (temperature,
//   gain / offset non-uniformity and drift)  4 Noise (white, row, column, 1/f)
//   5 Shutter FFC  6 ADC (14-bit raw)  7 AGC (linear or plateau equalisation, 8 bit).

#include <cstdint>
#include <filesystem>
#include <memory>

#include "sim/bolometer/camera.h"
#include "sim/bolometer/stages/stage.h"
#include "sim/core/image.h"

namespace nvs::bolometer {

// What one call did.
struct FrameInfo {
    std::uint64_t frame = 0;
    double t_s = 0.0;               // time of this frame since the first [s]
    double fpa_K = 0.0;             // focal-plane temperature [K]
    bool frozen = false;            // raw and display hold the last good frame (FFC under way)
    bool shutter_closed = false;    // the shutter is in front of the array
    bool ffc_started = false;       // an FFC began with this frame
    std::uint64_t ffc_count = 0;    // FFCs completed so far
    double since_ffc_s = 0.0;       // time since the last completed FFC [s]
    std::int64_t bad_input_px = 0;  // NaN, infinite or negative input (treated as 0)
    std::int64_t clipped_px = 0;    // raw counts clipped at 0 or full scale
    double mean_raw = 0.0;          // mean raw count of the output frame
    bool size_mismatch = false;     // input not width × height: nothing was computed
};

class BolometerChain {
  public:
    // configDir: the shipped data, for the optics' FFTW wisdom (<configDir>/fftw/), as the
    // intensified chain's; empty: no wisdom, the scalar estimated plans (the same bits, slower).
    // planning: FftPlanning::Measure / Patient plan anew (the wisdom tool; not bit-stable).
    BolometerChain(const ThermalCameraParams& cam, std::uint64_t seed,
                   const std::filesystem::path& configDir = {},
                   FftPlanning planning = FftPlanning::Shipped);
    BolometerChain(const BolometerChain&) = delete;
    BolometerChain& operator=(const BolometerChain&) = delete;

    // One frame of band radiance at the aperture [W m⁻² sr⁻¹], width × height. Never throws,
    // never allocates.
    const FrameInfo& process(ImageView<const float> radiance_W_m2_sr) noexcept;

    const ImageU16& raw() const { return raw_; }  // 0 … 2^bits − 1
    const ImageU8& display() const { return display_; }
    const FrameInfo& lastInfo() const { return info_; }
    const ThermalCameraParams& camera() const { return cam_; }
    // Stages, for tests.
    const FocalPlaneStage& focalPlane() const { return focal_; }
    const OpticsStage& optics() const { return optics_; }

  private:
    ThermalCameraParams cam_;
    std::uint64_t frame_ = 0;
    OpticsStage optics_;
    DetectorStage detector_;
    FocalPlaneStage focal_;
    NoiseStage noise_;
    ShutterStage shutter_;
    AdcStage adc_;
    AgcStage agc_;
    ImageF power_W_;
    std::unique_ptr<float[]> row_;  // one row of detector output [V]
    ImageU16 raw_;
    ImageU8 display_;
    double sumRaw_ = 0.0;  // sum of the raw counts of the output frame
    FrameInfo info_;
};

}  // namespace nvs::bolometer
