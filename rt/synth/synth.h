#pragma once
// Synthetic stages of known output, used until the renderer and camera model are plugged in,
// and by the runtime's tests and benchmarks.
//
// TestPatternRender — band radiance image band_W_m2_sr [W m⁻² sr⁻¹] (no Lpe: a camera converts
//   with its own k), every value known in closed form:
//   rows [0, 3h/4): eight vertical bars; bar i (x in [i·w/8, (i+1)·w/8)) has
//                   L_i = L_max · i / 7   (a radiance staircase from 0 to L_max).
//   rows [3h/4, h): the pose strip. Pixels with x < w · (yaw mod 2π)/2π have L_max/2; the
//                   rest 0: the heading is readable from the video. A square target of side
//                   s = max(2, h/8) at L_max moves right at `targetSpeed_px_s`:
//                   x₀ = floor(v·t mod (w − s)), y₀ = h − s; it is tagged object 1 (truth box).
// LinearCamera — counts = round(L / L_fullScale · (2^bits − 1)) of the band radiance L,
//   clamped to [0, 2^bits − 1]; no noise, no gain control (it applies what is commanded): an
//   ideal linear sensor, so the digital output of the pattern is known.
// HeldPlatform — the scenario's initial pose and camera settings, without telemetry.

#include "rt/loop/stages.h"

namespace nvs::rt {

class TestPatternRender final : public RenderStage {
  public:
    TestPatternRender(double radianceMax_W_m2_sr, double targetSpeed_px_s)
        : lMax_(radianceMax_W_m2_sr), speed_px_s_(targetSpeed_px_s) {}
    Outputs outputs() const noexcept override { return {false, true}; }
    void render(const FrameRequest& req, RadianceTarget out, FrameMeta& meta) noexcept override;
    double radianceMax_W_m2_sr() const { return lMax_; }

  private:
    double lMax_;
    double speed_px_s_;
};

class LinearCamera final : public CameraStage {
  public:
    LinearCamera(double fullScale_W_m2_sr, int bits) : fullScale_(fullScale_W_m2_sr), bits_(bits) {}
    int bits() const noexcept override { return bits_; }
    void expose(const FrameRequest& req, RadianceFrame in, ImageView<std::uint16_t> counts,
                FieldMeta& applied) noexcept override;

  private:
    double fullScale_;
    int bits_;
};

class HeldPlatform final : public PlatformSource {
  public:
    explicit HeldPlatform(const PlatformState& initial) : state_(initial) {}
    void sample(double t_sample_s, double now_s, PlatformState& out) noexcept override;
    std::string status() const override { return "held: scenario pose, no telemetry"; }

  private:
    PlatformState state_;
};

}  // namespace nvs::rt
