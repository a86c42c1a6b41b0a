#pragma once
// The uncooled microbolometer (sim/bolometer) as the runtime's CameraStage (docs/bolometer.md).
//
// Input: the band radiance the scene renderer draws for a thermal camera (Renderer::
// renderThermal, W m⁻² sr⁻¹ in the preset's band). Output: the 8-bit display frame (the
// preset's gain control: linear or plateau equalisation) when the scenario asks for 8 bits,
// else the raw ADC counts. The chain keeps its own state (focal-plane drift, shutter): one call
// per frame in order. Setup allocates everything; expose() allocates nothing and throws nothing.

#include <cstdint>
#include <filesystem>

#include "rt/loop/stages.h"
#include "sim/bolometer/chain.h"

namespace nvs::rt {

class BolometerCameraStage final : public CameraStage {
  public:
    // `cam` must have the loop's width and height; `bits` is 8 (display) or the ADC's depth.
    // The core's start-up shutter correction runs here, before the first frame, looking at a
    // uniform scene of `startRadiance_W_m2_sr` once the shutter opens (a camera powered up
    // before the run: its first frames are pictures, not frozen ones). configDir: the shipped
    // data (the optics' FFTW wisdom), as the intensified camera's.
    BolometerCameraStage(const bolometer::ThermalCameraParams& cam, int bits, std::uint64_t seed,
                         double startRadiance_W_m2_sr, const std::filesystem::path& configDir);

    int bits() const noexcept override { return bits_; }
    void expose(const FrameRequest& req, RadianceFrame in, ImageView<std::uint16_t> counts,
                FieldMeta& applied) noexcept override;

    const bolometer::FrameInfo& lastFrame() const { return chain_.lastInfo(); }

  private:
    int bits_;
    bolometer::BolometerChain chain_;
};

}  // namespace nvs::rt
