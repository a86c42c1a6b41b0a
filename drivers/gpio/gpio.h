#pragma once
// GPIO (DESIGN §6): a gate pulse per exposure on an output line, and edge events on an input
// line (an external trigger from the equipment under test). libgpiod 1.6 (v1 API) behind our own
// interface, with an in-memory fake.
//
//   GpioLine          one requested line: output (set value) or rising-edge input (wait for an
//                     edge with its kernel timestamp). 0 / -errno.
//   GpiodLine         libgpiod v1: gpiod_chip_open_by_name / gpiod_chip_get_line /
//                     gpiod_line_request_output / gpiod_line_set_value /
//                     gpiod_line_request_rising_edge_events / gpiod_line_event_wait / _read.
//                     RAII: the line is released and the chip closed on destruction.
//   FakeGpioLine      records every value set with its CLOCK_MONOTONIC time; edges are pushed.
//   GpioGateSink      rt::FrameSink: each emitted frame raises the line at emission and lowers
//                     it gate_s later (the frame's gate, or its exposure when ungated), from a
//                     pulse thread (rt/clock/threads.h: nvs-gpio) so the output thread never
//                     sleeps. A pulse still high when the next frame comes is cut short
//                     (counted as overlapped). Line errors are counted, never fatal.
//
// Output spec: gpio:CHIP:LINE[?active=high|low] — CHIP as gpiod_chip_open_by_name takes it
// ("gpiochip0"), LINE the offset on that chip; active=low drives the line low during the pulse.

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "rt/msg/stages.h"

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

class FakeGpioLine final : public GpioLine {
  public:
    struct Change {
        int value;
        std::int64_t t_ns;  // CLOCK_MONOTONIC
    };
    explicit FakeGpioLine(std::size_t capacity = 4096) { changes_.reserve(capacity); }
    int requestOutput(const std::string& chip, unsigned line, bool activeLow) override;
    int requestRisingEdges(const std::string& chip, unsigned line) override;
    int setValue(int value) noexcept override;
    int waitEdge(std::int64_t timeout_ns, std::int64_t* edge_ns) noexcept override;
    void release() noexcept override { state_ = GpioState::Closed; }
    GpioState state() const noexcept override { return state_; }
    const GpioCounters& counters() const noexcept override { return counters_; }

    std::string chip = "gpiochip0";  // the only chip that exists
    unsigned lines = 32;             // lines it has
    bool activeLow = false;
    void pushEdge(std::int64_t t_ns) { edges_.push_back(t_ns); }
    void fail(int err) { failErr_ = err; }  // from now on every call fails with -err
    // Written by setValue (up to the capacity given; read after the writer has stopped).
    const std::vector<Change>& changes() const { return changes_; }

  private:
    GpioState state_ = GpioState::Closed;
    GpioCounters counters_;
    std::vector<Change> changes_;
    std::deque<std::int64_t> edges_;
    int failErr_ = 0;
};

class GpioGateSink final : public rt::FrameSink {
  public:
    // Requests the line (throws SetupError naming the spec) and starts the pulse thread.
    GpioGateSink(std::unique_ptr<GpioLine> line, const std::string& chip, unsigned offset,
                 bool activeLow);
    ~GpioGateSink() override;
    const char* name() const noexcept override { return name_.c_str(); }
    int write(const rt::OutputFrame& frame) noexcept override;
    int close() noexcept override;
    std::string status() const override;
    std::int64_t pulses() const { return pulses_.load(); }
    std::int64_t overlapped() const { return overlapped_.load(); }

  private:
    void pulseThread();
    std::unique_ptr<GpioLine> line_;
    std::string name_;
    // One-slot mailbox: the output thread stores a request and bumps seq_.
    std::atomic<std::uint32_t> seq_{0};
    std::atomic<std::int64_t> width_ns_{0};
    std::atomic<bool> stop_{false};
    std::atomic<std::int64_t> pulses_{0};
    std::atomic<std::int64_t> overlapped_{0};
    std::atomic<std::int64_t> errors_{0};
    std::thread thread_;
    bool closed_ = false;
};

}  // namespace nvs::drivers
