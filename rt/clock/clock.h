#pragma once
// Frame clocks (docs/design.md §5). Both number ticks k = 0, 1, 2, … and put tick k at
//   t_k = k · dt   on the run clock (seconds since the run started),
// with dt = den/num seconds held as an exact rational so that 59.94 Hz (60000/1001) does not
// drift: the wall clock computes each absolute deadline from k with integer arithmetic
// instead of adding a rounded period (an added period accumulates its rounding error).
//
//   SimClock   never sleeps; t_k is computed, not measured, so two runs agree bit for bit.
//   WallClock  CLOCK_MONOTONIC; sleeps to each absolute deadline with
//              clock_nanosleep(TIMER_ABSTIME), which cannot drift when a sleep is cut short
//              or a frame is late: the next deadline does not depend on when we woke.

#include <cstdint>
#include <string>

#include "sim/msg/rate.h"

namespace nvs::rt {

// The exact rational rate the clocks tick at (sim/msg/rate.h: a file format carries it too).
using msg::FrameRate;

std::int64_t monotonicNow_ns() noexcept;
std::int64_t realtimeNow_ns() noexcept;

class SimClock {
  public:
    // Throws SetupError for a rate that is not FrameRate::valid().
    explicit SimClock(FrameRate rate) : rate_(rate.checked("sim clock")) {}
    FrameRate rate() const { return rate_; }
    // t_k = k·dt [s] on the run clock, computed from k alone.
    double tickTime_s(std::int64_t k) const {
        return static_cast<double>(k) * static_cast<double>(rate_.den) /
               static_cast<double>(rate_.num);
    }

  private:
    FrameRate rate_;
};

class WallClock {
  public:
    // Throws SetupError for a rate that is not FrameRate::valid(): num ≥ 1 keeps the
    // divisions below defined, num, den ≤ 10⁹ keep the 128-bit products from overflowing.
    explicit WallClock(FrameRate rate) : rate_(rate.checked("wall clock")) {}
    FrameRate rate() const { return rate_; }
    // Fixes the run clock's origin (tick 0) at `start_ns` on CLOCK_MONOTONIC.
    void start(std::int64_t start_ns) noexcept { start_ns_ = start_ns; }
    std::int64_t start_ns() const { return start_ns_; }
    // Absolute deadline of tick k on CLOCK_MONOTONIC: start + floor(k·den·1e9/num).
    std::int64_t deadline_ns(std::int64_t k) const noexcept;
    double tickTime_s(std::int64_t k) const {
        return static_cast<double>(deadline_ns(k) - start_ns_) * 1e-9;
    }
    // The last tick whose deadline is at or before `t_ns` (−1 before the start).
    std::int64_t tickAt(std::int64_t t_ns) const noexcept;
    // Run-clock seconds of a CLOCK_MONOTONIC instant.
    double runTime_s(std::int64_t t_ns) const {
        return static_cast<double>(t_ns - start_ns_) * 1e-9;
    }
    // Sleeps until the absolute deadline (returns at once if it has passed). Returns 0, or
    // -EINTR when a signal interrupted it (the caller checks its stop flag and calls again).
    static int sleepUntil(std::int64_t deadline_ns) noexcept;

  private:
    FrameRate rate_;
    std::int64_t start_ns_ = 0;
};

// Real-time scheduling for the calling thread: SCHED_FIFO at `priority` and, when cpu >= 0,
// pinned to that CPU. Returns 0 or -errno; on failure `message` says what to do about it
// (the run goes on with normal scheduling).
int makeThreadRealtime(int priority, int cpu, std::string& message);
// Locks current and future pages in memory (mlockall) so page faults cannot stall the loop.
int lockMemory(std::string& message);

}  // namespace nvs::rt
