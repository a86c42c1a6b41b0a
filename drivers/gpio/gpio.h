#pragma once
// GPIO (docs/design.md §6): a gate pulse per exposure on an output line, and edge events on an
// input line (an external trigger from the equipment under test). libgpiod 1.6 (v1 API) behind our
// own interface, with an in-memory fake.
//
//   GpioLine          one requested line: output (set value) or rising-edge input (wait for an
//                     edge with its kernel timestamp). 0 / -errno.
//   GpiodLine         libgpiod v1: gpiod_chip_open_by_name / gpiod_chip_get_line /
//                     gpiod_line_request_output / gpiod_line_set_value /
//                     gpiod_line_request_rising_edge_events / gpiod_line_event_wait / _read.
//                     RAII: the line is released and the chip closed on destruction.
//   FakeGpioLine      the in-memory line for tests (drivers/gpio/fake, a test-only target).
//   GpioGateSink      msg::FrameSink, msg::ExposureObserver and msg::SinkWorker: one pulse per
//                     exposure (frame, or field when interlaced), marking the exposure window
//                     on the loop's timeline. The camera thread schedules each exposure ahead
//                     of emission (exposureScheduled: start on CLOCK_MONOTONIC, gate); the
//                     pulse loop, runWorker(), which the runtime runs on its nvs-gpio thread
//                     (the driver starts no thread), sleeps to the start with an absolute
//                     clock_nanosleep, raises the line, and lowers it at start + width (also
//                     absolute), width = gate_s when 0 < gate_s < exposure, else the exposure.
//                     A request that comes after its start (trigger clock, a late render) rises
//                     at once, still falls at the window's end (at once when that has passed)
//                     and is counted late; one that starts before the previous pulse has ended
//                     (windows that overlap) rises when it ends and is counted overlapped. Line
//                     errors are counted, never fatal. Under the sim clock (no wall time) a pulse
//                     rises as soon as its exposure is scheduled. stopWorker() lets the pulses
//                     already scheduled finish before runWorker() returns; close() waits for
//                     it to return, then lowers and releases the line.
//   GpioTrigger       msg::TriggerSource: rising edges of an input line with the kernel's
//                     timestamps, on CLOCK_MONOTONIC (the v1 uAPI stamps events with
//                     CLOCK_MONOTONIC since Linux 5.7 and CLOCK_REALTIME before: a stamp closer
//                     to CLOCK_REALTIME is moved onto CLOCK_MONOTONIC).
//
// Output spec: gpio:CHIP:LINE[?active=high|low] — CHIP as gpiod_chip_open_by_name takes it
// ("gpiochip0"), LINE the offset on that chip; active=low drives the line low during the pulse.
// Trigger spec (scenario [runtime] trigger): gpio:CHIP:LINE.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>

#include "sim/msg/output.h"

struct gpiod_chip;
struct gpiod_line;

namespace nvs::drivers {

enum class GpioState : std::uint8_t { Closed, Output, Input, Failed };

struct GpioCounters {
    std::int64_t sets = 0;    // values written
    std::int64_t edges = 0;   // edges read
    std::int64_t errors = 0;  // failed calls after setup
    int lastErrno = 0;
};

class GpioLine {
  public:
    virtual ~GpioLine() = default;
    // Requests `line` of `chip` as an output at its inactive level. `activeLow`: logical 1
    // drives the pin low.
    virtual int requestOutput(const std::string& chip, unsigned line, bool activeLow) = 0;
    // Requests `line` of `chip` for rising-edge events.
    virtual int requestRisingEdges(const std::string& chip, unsigned line) = 0;
    // Logical value (1 active). 0 / -errno.
    virtual int setValue(int value) noexcept = 0;
    // Waits up to `timeout_ns` for an edge: 1 and its kernel timestamp [ns], 0 on timeout,
    // -errno on failure.
    virtual int waitEdge(std::int64_t timeout_ns, std::int64_t* edge_ns) noexcept = 0;
    virtual void release() noexcept = 0;
    virtual GpioState state() const noexcept = 0;
    virtual const GpioCounters& counters() const noexcept = 0;
};

class GpiodLine final : public GpioLine {
  public:
    GpiodLine() = default;
    ~GpiodLine() override { release(); }
    GpiodLine(const GpiodLine&) = delete;
    GpiodLine& operator=(const GpiodLine&) = delete;
    int requestOutput(const std::string& chip, unsigned line, bool activeLow) override;
    int requestRisingEdges(const std::string& chip, unsigned line) override;
    int setValue(int value) noexcept override;
    int waitEdge(std::int64_t timeout_ns, std::int64_t* edge_ns) noexcept override;
    void release() noexcept override;
    GpioState state() const noexcept override { return state_; }
    const GpioCounters& counters() const noexcept override { return counters_; }

  private:
    int open(const std::string& chip, unsigned line);
    gpiod_chip* chip_ = nullptr;
    gpiod_line* line_ = nullptr;
    GpioState state_ = GpioState::Closed;
    GpioCounters counters_;
};

// CLOCK_MONOTONIC now [ns], the clock of line event stamps and of the loop's timeline (a kernel
// interface, read directly).
std::int64_t gpioMonotonicNow_ns() noexcept;

class GpioGateSink final : public msg::FrameSink,
                           public msg::ExposureObserver,
                           public msg::SinkWorker {
  public:
    // Requests the line (throws SetupError naming the spec). Pulses need runWorker() running.
    GpioGateSink(std::unique_ptr<GpioLine> line, const std::string& chip, unsigned offset,
                 bool activeLow);
    ~GpioGateSink() override;
    const char* name() const noexcept override { return name_.c_str(); }
    // Reads nothing of the frame and never blocks: called on the output thread, no queue.
    msg::SinkInputs inputs() const noexcept override { return {false, false, true}; }
    // Emission: nothing to do (pulses follow exposures); reports line errors to the loop.
    int write(const msg::OutputFrame& frame) noexcept override;
    int close() noexcept override;
    std::string status() const override;
    // Camera thread: queue the pulse of one exposure.
    void exposureScheduled(const msg::ExposureWindow& w) noexcept override;
    // The pulse loop: sleeps to each queued pulse's edges and drives the line; returns once
    // stopWorker() has been called and the queue is empty (or at once after close()).
    void runWorker() noexcept override;
    void stopWorker() noexcept override;
    std::int64_t pulses() const { return pulses_.load(); }
    std::int64_t overlapped() const { return overlapped_.load(); }
    std::int64_t late() const { return late_.load(); }
    std::int64_t queuedLate() const { return queuedLate_.load(); }
    std::int64_t lost() const { return lost_.load(); }

  private:
    struct Pulse {
        std::int64_t start_ns = 0;  // CLOCK_MONOTONIC; 0: as soon as possible
        std::int64_t width_ns = 0;
    };
    static constexpr std::uint32_t kQueue = 16;
    void noteError(int rc) noexcept;  // pulse thread: a failed set (rc = -errno)
    std::unique_ptr<GpioLine> line_;
    std::string name_;
    // Single-producer (camera thread) single-consumer (runWorker) queue of pulses.
    Pulse queue_[kQueue];
    std::atomic<std::uint32_t> head_{0};
    std::atomic<std::uint32_t> tail_{0};
    std::atomic<std::uint32_t> wake_{0};  // bumped on every push and at close
    std::atomic<bool> stop_{false};
    std::atomic<std::int64_t> pulses_{0};
    std::atomic<std::int64_t> overlapped_{0};
    std::atomic<std::int64_t> late_{0};  // rose more than kLate_ns after the exposure start
    // Handed over (exposureScheduled) after the exposure's start: late before the pulse thread
    // saw it, which tells a late frame from a late wake-up.
    std::atomic<std::int64_t> queuedLate_{0};
    // The latest a pulse rose after its exposure's start (the clock read just before the line
    // is set): the pulse thread's wake-up delay, in the status line.
    std::atomic<std::int64_t> riseDelayMax_ns_{0};
    std::atomic<std::int64_t> lost_{0};  // queue full: the render ran far ahead
    std::atomic<std::int64_t> errors_{0};
    // errno of the last failed set, for write() and status() on other threads: the line's own
    // counters belong to the pulse thread until close() has waited for it.
    std::atomic<int> lastErrno_{0};
    std::atomic<bool> active_{false};  // runWorker() is running
    std::atomic<bool> closed_{false};
};

// Late: a rise more than this after its exposure start (wake-up delays are shorter on an idle
// machine).
inline constexpr std::int64_t kGateLate_ns = 1'000'000;

class GpioTrigger final : public msg::TriggerSource {
  public:
    // Requests the line for rising edges (throws SetupError naming the spec).
    GpioTrigger(std::unique_ptr<GpioLine> line, const std::string& chip, unsigned offset);
    const char* name() const noexcept override { return name_.c_str(); }
    int waitEdge(std::int64_t timeout_ns, std::int64_t* edgeMonotonic_ns) noexcept override;
    std::string status() const override;

  private:
    std::unique_ptr<GpioLine> line_;
    std::string name_;
    std::int64_t realtimeStamps_ = 0;  // edges stamped on CLOCK_REALTIME (kernels before 5.7)
};

// "CHIP:LINE" → chip and line offset (false when malformed).
bool parseGpioTarget(const std::string& target, std::string* chip, unsigned* line);

}  // namespace nvs::drivers
