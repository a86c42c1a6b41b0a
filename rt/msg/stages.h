#pragma once
// The interfaces through which the frame loop drives its stages and sinks. The loop calls them
// only from its own threads (rt/clock/threads.h) with preallocated buffers; implementations
// must not allocate, throw or block for long inside these calls (STYLE §3, §8).
//
//   PlatformSource  telemetry → PlatformState at the exposure's mid-time   (render thread)
//   RenderStage     FrameRequest → radiance image [W m⁻² sr⁻¹] + truth   (render thread)
//   CameraStage     radiance image → digital counts (ADC bits)           (render thread)
//   FrameSink       one emitted frame → a device or file                 (output thread)
//   ExposureObserver an exposure scheduled on the loop's timeline        (render thread)
//   TriggerSource   rising edges that start exposures (trigger clock)    (render thread)
//
// The synthetic stages in rt/synth stand in until the renderer and the camera model
// (sim/sensor) are plugged in through the same two interfaces.

#include <cstdint>
#include <string>

#include "rt/msg/messages.h"
#include "sim/core/image.h"

namespace nvs::rt {

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
    virtual ~RenderStage() = default;
    // Fills `radiance_W_m2_sr` (the output's size) and the truth boxes of `meta`.
    virtual void render(const FrameRequest& req, ImageView<float> radiance_W_m2_sr,
                        FrameMeta& meta) noexcept = 0;
};

class CameraStage {
  public:
    virtual ~CameraStage() = default;
    // ADC bit depth of the counts it produces (1..16).
    virtual int bits() const noexcept = 0;
    // Exposes the radiance image; may update meta.platform.gain_V / gate_s (AGC).
    virtual void expose(const FrameRequest& req, ImageView<const float> radiance_W_m2_sr,
                        ImageView<std::uint16_t> counts, FrameMeta& meta) noexcept = 0;
};

// One frame as the output thread hands it to every sink.
struct OutputFrame {
    const FrameMeta* meta = nullptr;
    ImageView<const float> radiance_W_m2_sr;
    ImageView<const std::uint16_t> counts;
    int bits = 8;                       // significant bits of counts
    std::int64_t tick = 0;              // the tick it is emitted on
    bool repeat = false;                // a repeat of the previous frame (late-frame policy)
    double emit_s = 0.0;                // run-clock time of emission
    std::int64_t emitMonotonic_ns = 0;  // CLOCK_MONOTONIC of emission (0 under the sim clock)
};

// The exposure of one frame or field, on the loop's timeline, as the render thread schedules it
// (before the frame is emitted: rendering runs ahead of the output).
struct ExposureWindow {
    std::int64_t frame = 0;
    std::int32_t field = 0;   // 0, or 1 for the second field of an interlaced frame
    double t_sample_s = 0.0;  // exposure mid-time (run clock)
    double start_s = 0.0;     // exposure start = t_sample_s − exposure_s/2 (run clock)
    double exposure_s = 0.0;  // integration time of the frame or field
    double gate_s = 0.0;      // photocathode gate applied (≤ exposure_s; 0: continuous)
    std::int64_t startMonotonic_ns = 0;  // start_s on CLOCK_MONOTONIC; 0 under the sim clock
};

// Told of every exposure as soon as it is scheduled (render thread, after the camera stage, so
// the gate the camera applied is known). A sink that also implements this interface is
// registered by the frame loop automatically (the GPIO gate pulse, drivers/gpio).
class ExposureObserver {
  public:
    virtual ~ExposureObserver() = default;
    virtual void exposureScheduled(const ExposureWindow& w) noexcept = 0;
};

// External trigger input (the trigger clock, rt/loop/frame_loop.h): rising edges from the
// equipment under test, each starting one exposure.
class TriggerSource {
  public:
    virtual ~TriggerSource() = default;
    virtual const char* name() const noexcept = 0;
    // Waits up to `timeout_ns` (0: does not wait) for the next rising edge: 1 and its time on
    // CLOCK_MONOTONIC, 0 on timeout, -errno on failure.
    virtual int waitEdge(std::int64_t timeout_ns, std::int64_t* edgeMonotonic_ns) noexcept = 0;
    // Counters and state, one line (end of run; may allocate).
    virtual std::string status() const = 0;
};

class FrameSink {
  public:
    virtual ~FrameSink() = default;
    virtual const char* name() const noexcept = 0;
    // 0, or -errno. A failing sink counts the error and stays usable or closed, as it says.
    virtual int write(const OutputFrame& frame) noexcept = 0;
    // Finishes the output (renames a temporary file into place). 0 or -errno.
    virtual int close() noexcept = 0;
    // Counters and state, one line (end of run; may allocate).
    virtual std::string status() const = 0;
};

}  // namespace nvs::rt
