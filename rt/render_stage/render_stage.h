#pragma once
// The renderer as the runtime's render stage (rt/loop/stages.h).
//
// UNITS: the stage writes the photoelectron radiance at the lens, Lpe [pe s⁻¹ m⁻² sr⁻¹] in the
// scenario camera's band (docs/design.md §3) — what the IICCD chain consumes directly — and the
// band-integrated radiance [W m⁻² sr⁻¹] of the same frame into the target's band image (the EXR
// sink, comparison with the thesis); without a band image it renders that band into scratch.
//
// Per frame it takes from the request:
//   time     the platform's UTC (telemetry time) if set, else the scenario epoch + t_sample_s;
//   pose     when the platform state carries one (poseFromTelemetry: telemetry's, or the
//            scenario's [platform] pose when it states one): latitude, longitude, altitude and
//            the aerospace yaw/pitch/roll of the body, mapped to the scene by PlatformPose
//            (rt/compose/platform_pose.h). Otherwise the scene's own camera is used (a fixed
//            camera such as the RIT roof);
//   lamps    bit i of lampMask switches lamp i (scene order) on;
//   rows     rowParity ≥ 0 (field_rows = "own"): only that parity's rows are rendered, into the
//            stage's own images, whose other rows keep the previous field's radiance;
// and it writes the truth boxes of the scene's tracked objects into the frame's metadata.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "rt/compose/platform_pose.h"
#include "rt/compose/rig.h"
#include "rt/compose/scene_setup.h"
#include "rt/compose/thermal_scene.h"
#include "rt/loop/stages.h"
#include "rt/render_stage/row_pool.h"

namespace nvs::rt {

class SceneRenderStage final : public RenderStage {
  public:
    // Setup: the scenario's scene, camera bands, sky and renderer (rt/compose), rendered at the
    // scenario's size with its coarse tiles on its render threads, data and caches from dirs
    // (throws SetupError).
    static std::unique_ptr<SceneRenderStage> create(const Scenario& scenario, const DataDirs& dirs);

    // Both images: Lpe for the camera, and the band radiance of the same frame.
    // A thermal camera: the band radiance of the thermal band only (Renderer::renderThermal).
    Outputs outputs() const noexcept override { return {!thermal_, true}; }
    void render(const FrameRequest& req, RadianceTarget out, FrameMeta& meta) noexcept override;

    // Lamps of the scene switched on by the scenario at the start, as a lamp mask.
    std::uint32_t initialLampMask() const { return initialLamps_; }
    const ScenarioRenderer& scenario() const { return *sr_; }
    double epochUnix_s() const { return epochUnix_s_; }

    // The scene-frame camera pose for a platform state (exposed for tests).
    scene::CameraPose poseFor(const PlatformState& p) const noexcept;
    // A pose the renderer can take: every component finite and within 10⁸ m.
    static bool poseUsable(const scene::CameraPose& pose) noexcept;
    // Frames rendered with the last good time or camera because the request's platform state
    // was not finite (never expected: telemetry is checked where it enters).
    const ThermalScene* thermal() const noexcept { return thermal_.get(); }
    // The renderer's primary-visibility line (Renderer::primaryVisibilityNote), chosen at setup.
    const std::string& primaryVisibilityNote() const noexcept { return visibilityNote_; }
    std::int64_t heldFrames() const noexcept { return heldFrames_.load(std::memory_order_relaxed); }
    // A rig's channel (Scenario::channelIndex ≥ 0): every channel's pinhole, by index, for the
    // ground-plane homographies of its metadata (set before the first frame).
    void setRigPinholes(const render::PinholeCamera* pins, int count) noexcept;

  private:
    // A rig's channel: the camera as mounted (and, with a misregistration, as it truly looks);
    // its published geometry and homographies into `meta`.
    bool poseRig(const PlatformState& p) noexcept;
    void publishRig(std::int64_t frame, FrameMeta& meta) const noexcept;
    void setUpRig(const Scenario& sc);
    SceneRenderStage() = default;
    std::unique_ptr<ScenarioRenderer> sr_;
    std::unique_ptr<ThermalScene> thermal_;  // with a thermal camera
    std::unique_ptr<RowPool> pool_;
    std::string visibilityNote_;
    ImageF band_;  // scratch band image when the target has none
    // field_rows = "own": the images the renderer fills a field's rows of, in place (the other
    // rows hold the previous field's), copied out whole; valid once every row was rendered.
    ImageF heldLpe_, heldBand_;
    bool holdRows_ = false, heldValid_ = false;
    double epochUnix_s_ = 0.0;
    double lastGoodT_s_ = 0.0;
    std::atomic<std::int64_t> heldFrames_{0};
    PlatformPose pose_;
    std::uint32_t initialLamps_ = 0;
    int lampCount_ = 0;
    render::Renderer::ObjectTruth truth_[kMaxTruthBoxes] = {};
    // A rig's channel (rt/compose/rig.h).
    bool rig_ = false;
    scene::CameraPose sceneCamera_;  // the platform's camera without telemetry
    scene::CameraPose base_;         // the platform's camera of the frame in hand
    scene::CameraPose published_;    // this channel's camera as mounted (published)
    Mount mounts_[msg::kMaxChannels];
    Mount misregistration_;
    render::PinholeCamera pins_[msg::kMaxChannels];
    msg::RigMeta rigMeta_;  // its constant part
    RigClock rigClock_;
};

}  // namespace nvs::rt
