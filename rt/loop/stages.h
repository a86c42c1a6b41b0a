#pragma once
// The interfaces through which the frame loop drives its stages, and the names of the typed
// messages (sim/msg) as the runtime uses them. The loop calls the stages only from its own
// threads (rt/clock/threads.h) with preallocated buffers; implementations must not allocate,
// throw or block for long inside these calls (docs/style.md §3, §8).
//
//   PlatformSource  telemetry → PlatformState (as commanded) at the exposure's mid-time
//   RenderStage     FrameRequest → radiance images (RadianceTarget, each in its unit) + truth
//   CameraStage     radiance → digital counts (ADC bits) + what it applied (FieldMeta)
//
// These three stay in rt: only the runtime calls them. What drivers implement (FrameSink,
// ExposureObserver, TriggerSource, SinkWorker) is in sim/msg/output.h, below both.

#include <cstdint>
#include <string>

#include "sim/core/image.h"
#include "sim/msg/frame.h"
#include "sim/msg/output.h"
#include "sim/msg/platform.h"

namespace nvs::rt {

using msg::ExposureObserver;
using msg::ExposureWindow;
using msg::FieldMeta;
using msg::FrameMeta;
using msg::FrameRequest;
using msg::FrameSink;
using msg::kMaxFields;
using msg::kMaxTruthBoxes;
using msg::OutputFrame;
using msg::PlatformState;
using msg::RadianceFrame;
using msg::RadianceTarget;
using msg::SinkWorker;
using msg::TriggerSource;
using msg::TruthBox;

class PlatformSource {
  public:
    virtual ~PlatformSource() = default;
    // Takes in every telemetry message received by run-clock time `now_s` and fills `out` with
    // the platform state at `t_sample_s` (interpolated, or extrapolated and maybe stale).
    virtual void sample(double t_sample_s, double now_s, PlatformState& out) noexcept = 0;
    // Counters and state, one line (end of run; may allocate).
    virtual std::string status() const = 0;
    // True when bad input was configured to be fatal and has occurred.
    virtual bool failed() const noexcept { return false; }
};

class RenderStage {
  public:
    // The images a stage fills, fixed at setup: the loop allocates only these.
    struct Outputs {
        bool lpe_pe_s_m2_sr = false;
        bool band_W_m2_sr = false;
    };
    virtual ~RenderStage() = default;
    virtual Outputs outputs() const noexcept = 0;
    // Fills the images of `out` that outputs() names (the output's size; the others are
    // empty) and the truth boxes of `meta`.
    virtual void render(const FrameRequest& req, RadianceTarget out, FrameMeta& meta) noexcept = 0;
};

class CameraStage {
  public:
    virtual ~CameraStage() = default;
    // ADC bit depth of the counts it produces (1..16).
    virtual int bits() const noexcept = 0;
    // Exposes the radiance and writes the counts. `applied` arrives holding the commanded
    // values (req.platform's gain_V and gate_s at req.t_sample_s); a camera that controls its
    // gain or gate (AGC, autogate) overwrites them with what it applied.
    virtual void expose(const FrameRequest& req, RadianceFrame in, ImageView<std::uint16_t> counts,
                        FieldMeta& applied) noexcept = 0;
};

}  // namespace nvs::rt
