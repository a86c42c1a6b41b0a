#pragma once
// What the runtime hands its outputs, and the interfaces drivers implement (docs/style.md §5, §10).
// The runtime calls them only from its own threads (rt/clock/threads.h) with preallocated
// buffers; implementations must not allocate, throw or block for long inside these calls
// (docs/style.md §3, §8), except status() at the end of a run.
//
//   FrameSink         one emitted frame → a device or file                 (output thread)
//   ExposureObserver  an exposure scheduled on the loop's timeline         (camera thread)
//   TriggerSource     rising edges that start exposures (trigger clock)    (render thread)
//   SinkWorker        a driver's own blocking work (the GPIO pulse train), run by the runtime
//                     on a thread of its thread table: drivers start no thread themselves.

#include <cstdint>
#include <string>

#include "sim/core/image.h"
#include "sim/msg/frame.h"

namespace nvs::msg {

// How the rows of an emitted frame were exposed: all at once, or as two fields, the field on
// the top (even) rows first or the one on the bottom (odd) rows first. Sinks that can say so
// (y4m "Ip"/"It"/"Ib", V4L2 field NONE/INTERLACED_TB/INTERLACED_BT) do.
enum class FieldOrder : std::uint8_t { Progressive, TopFirst, BottomFirst };

// One frame as the output thread hands it to every sink.
struct OutputFrame {
    const FrameMeta* meta = nullptr;
    RadianceFrame radiance;  // the render stage's images (either may be empty)
    ImageView<const std::uint16_t> counts;
    int bits = 8;                       // significant bits of counts
    std::int64_t tick = 0;              // the tick it is emitted on
    bool repeat = false;                // a repeat of the previous frame (late-frame policy)
    double emit_s = 0.0;                // run-clock time of emission [s]
    std::int64_t emitMonotonic_ns = 0;  // CLOCK_MONOTONIC of emission (0 under the sim clock)
};

// The exposure of one frame or field, on the loop's timeline, as the runtime schedules it
// (before the frame is emitted: rendering runs ahead of the output).
struct ExposureWindow {
    std::int64_t frame = 0;
    std::int32_t field = 0;   // 0, or 1 for the second field of an interlaced frame
    double t_sample_s = 0.0;  // exposure mid-time (run clock) [s]
    double start_s = 0.0;     // exposure start = t_sample_s − exposure_s/2 (run clock) [s]
    double exposure_s = 0.0;  // integration time of the frame or field [s]
    double gate_s = 0.0;      // photocathode gate applied (≤ exposure_s; 0: continuous) [s]
    std::int64_t startMonotonic_ns = 0;  // start_s on CLOCK_MONOTONIC; 0 under the sim clock
};

// Told of every exposure as soon as it is scheduled (after the camera stage, so the gate the
// camera applied is known). A sink that also implements this interface is registered by the
// frame loop automatically (the GPIO gate pulse, drivers/gpio).
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

// What a sink reads of an OutputFrame, fixed at setup. The runtime gives every sink a bounded
// queue of its own and a thread that calls write() (rt/loop/sink_channel.h), copying into the
// queue only what the sink reads; a `direct` sink (its write() never blocks and copies nothing
// it keeps: the GPIO gate) is called on the output thread instead.
struct SinkInputs {
    bool counts = true;     // OutputFrame::counts
    bool radiance = false;  // OutputFrame::radiance
    bool direct = false;
};

class FrameSink {
  public:
    virtual ~FrameSink() = default;
    virtual const char* name() const noexcept = 0;
    virtual SinkInputs inputs() const noexcept { return {}; }
    // 0, or -errno. A failing sink counts the error and stays usable or closed, as it says.
    // Called from one thread only (the sink's own, or the output thread for a direct sink).
    virtual int write(const OutputFrame& frame) noexcept = 0;
    // True once the sink can write nothing more (a stream whose reader went away, a file
    // abandoned after an I/O error). Asked on the thread that calls write(), after each write.
    virtual bool failed() const noexcept { return false; }
    // Any thread: abandon a write that is blocked on a consumer (a pipe nobody reads), now and
    // from now on; writes that do not block still complete. Used when a run is stopped.
    virtual void cancel() noexcept {}
    // Finishes the output (renames a temporary file into place). 0 or -errno. Called after
    // the runtime has stopped and joined the sink's worker, if it has one.
    virtual int close() noexcept = 0;
    // Counters and state, one line (end of run; may allocate).
    virtual std::string status() const = 0;
};

// Blocking work a driver needs done apart from the frame loop's threads (the GPIO gate sink
// sleeps to each pulse edge). The runtime calls runWorker() on a thread it starts from its
// thread table, stopWorker() when the loop has stopped, and then joins that thread.
class SinkWorker {
  public:
    virtual ~SinkWorker() = default;
    // Runs until stopWorker() has been called and the work already queued is done.
    virtual void runWorker() noexcept = 0;
    // Asks runWorker() to return (any thread; does not wait).
    virtual void stopWorker() noexcept = 0;
};

}  // namespace nvs::msg
