#pragma once
// The IICCD camera model (sim/sensor) as the runtime's CameraStage.
//
// Each loop frame is one call of the chain: a field (preset scan = "field") or a frame (scan =
// "frame"); the loop's rate is the chain's field or frame rate. In field scan the video frame is
// woven: each call rewrites the rows of its field's parity and keeps the other field's rows
// from the call before, as the interlaced camera's output does, so every emitted frame holds two
// fields, each exposed at its own t_sample_s.
//
// Input conversion: the render stage gives band radiance L [W m⁻² sr⁻¹]; the chain takes
// photoelectron radiance Lpe = L·k [pe s⁻¹ m⁻² sr⁻¹], with k = peRadiancePerBandRadiance(camera,
// spectrum) computed once at setup (sim/sensor/camera.h; `spectrum` flat | blackbody:T | moon |
// night_sky names the source spectrum's shape). With spectrum "pe" the render stage already
// gives photoelectron radiance (the scene renderer, rt/render_stage) and k = 1.
//
// Controls per frame (Controls::Platform, the default): the camera obeys the platform state
// (telemetry, or the scenario's held [platform] values):
//   agc = false      manual: gain_V from the platform, clamped to [0, agc_max_gain_V]
//   agc = true       the preset's automatic loop (agc, abc, bsp or autogate); a preset whose
//                    agc is "off" runs the plain AGC loop (camera's AGC switch turned on)
//   gate             automatic (the autogate loop's scale on the preset gate) when the preset's
//                    loop is autogate and either agc = true or gate_mode = 2; otherwise by
//                    gate_mode: 0 continuous (the photocathode is on for the whole field),
//                    1 or 2 gated at the platform's gate_s, clamped to [gate_min_s, field]
//                    (a gate_s of 0 keeps the preset's gate)
// With Controls::Preset the platform's camera fields are ignored and the chain runs exactly as
// sim/sensor's IiccdChain does with the preset (a test holds the two equal bit for bit).
// The gain and gate applied are written back into the frame's metadata.
//
// The stages are sim/sensor's public stage classes, run in IiccdChain::process's order with
// the controls above supplied per field (IiccdChain takes them from the preset only). Setup
// allocates everything; expose() allocates nothing and throws nothing.

#include <cstdint>
#include <filesystem>
#include <string>

#include "rt/msg/stages.h"
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

    int bits() const noexcept override { return cam_.adc_bits; }
    void expose(const FrameRequest& req, ImageView<const float> radiance_W_m2_sr,
                ImageView<std::uint16_t> counts, FrameMeta& meta) noexcept override;

    const sensor::FieldInfo& lastField() const { return info_; }
    const sensor::CameraParams& camera() const { return cam_; }
    double lpePerRadiance() const { return lpePerL_; }
    // The woven output frame (as copied into the loop's counts).
    const ImageU16& video() const { return video_; }

  private:
    static sensor::CameraParams autoParams(const sensor::CameraParams& cam);

    const sensor::CameraParams cam_;
    const sensor::CameraParams camAuto_;  // cam_ with its automatic loop switched on
    Controls controls_;
    double lpePerL_;
    std::uint64_t field_ = 0;
    sensor::OpticsStage optics_;
    sensor::GateStage gate_;
    sensor::PhotocathodeStage cathode_;
    sensor::BspStage bsp_;
    sensor::McpStage mcp_;
    sensor::PhosphorStage phosphor_;
    sensor::BlurStage blur_;
    sensor::CcdStage ccd_;
    sensor::VideoStage videoStage_;
    sensor::AgcLoop agcPreset_;  // the preset's own loop (Controls::Preset)
    sensor::AgcLoop agcAuto_;    // the loop used when the platform turns AGC on
    ImageF lpe_;
    ImageF rate_;
    ImageF sig_;
    ImageF countsF_;
    ImageU16 video_;
    sensor::FieldInfo info_;
};

}  // namespace nvs::rt
