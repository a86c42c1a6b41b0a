#pragma once
// The IICCD camera model (sim/sensor) as the runtime's CameraStage.
//
// Each loop frame is one call of the chain: a field (preset scan = "field") or a frame (scan =
// "frame"); the loop's rate is the chain's field or frame rate. In field scan the video frame is
// woven: each call rewrites the rows of its field's parity and keeps the other field's rows
// from the call before, as the interlaced camera's output does, so every emitted frame holds two
// fields, each exposed at its own t_sample_s.
//
// Input: the chain takes photoelectron radiance Lpe [pe s⁻¹ m⁻² sr⁻¹]. A render stage that gives
// only band radiance L [W m⁻² sr⁻¹] (the test pattern) is converted, Lpe = L·k, with
// k = peRadiancePerBandRadiance(camera, spectrum) computed once at setup (sim/sensor/camera.h;
// `spectrum` flat | blackbody:T | moon | night_sky names the source spectrum's shape). The
// scene renderer (rt/render_stage) gives Lpe itself, with spectrum "pe" and k = 1.
//
// The controls (manual gain, the automatic loops, the gate) are the chain's own policy
// (sim/sensor/chain.h, ControlSource): with Controls::Platform each field's command is the
// platform state's gain_V, agc, gate_s and gate_mode; with Controls::Preset the chain runs on
// its preset alone. This stage converts units, hands the command over and copies the woven
// video out; it does no physics. What the camera applied (gain, gate) is the field's
// metadata. Setup allocates everything; expose() allocates nothing and throws nothing.

#include <cstdint>
#include <filesystem>
#include <string>

#include "rt/loop/stages.h"
#include "sim/core/image.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"

namespace nvs::rt {

class IiccdCameraStage final : public CameraStage {
  public:
    enum class Controls { Platform, Preset };

    // `cam` must already have the loop's width and height and the field rate matching the
    // loop's rate (rt/run does that). Spectra and FFTW wisdom from configDir; the MCP's Gamma
    // tables from gammaTables. Throws SetupError for an unknown spectrum.
    IiccdCameraStage(const sensor::CameraParams& cam, const std::string& spectrum,
                     std::uint64_t seed, Controls controls, const std::filesystem::path& configDir,
                     GammaTableCache& gammaTables);
    IiccdCameraStage(const IiccdCameraStage&) = delete;
    IiccdCameraStage& operator=(const IiccdCameraStage&) = delete;

    int bits() const noexcept override { return chain_.camera().adc_bits; }
    void expose(const FrameRequest& req, RadianceFrame in, ImageView<std::uint16_t> counts,
                FieldMeta& applied) noexcept override;

    // Splits the chain's rows over `exec` (setup; it must outlive the stage). The same bits with
    // any executor (tests/sim/sensor/threads_test.cpp).
    void setExecutor(RowExecutor* exec) noexcept { chain_.setExecutor(exec); }

    const sensor::FieldInfo& lastField() const { return chain_.lastInfo(); }
    const sensor::CameraParams& camera() const { return chain_.camera(); }
    double lpePerRadiance() const { return lpePerL_; }
    // The woven output frame (as copied into the loop's counts).
    const ImageU16& video() const { return chain_.video(); }

  private:
    double lpePerL_;
    sensor::IiccdChain chain_;
    ImageF lpe_;  // band radiance converted to photoelectron radiance
};

}  // namespace nvs::rt
