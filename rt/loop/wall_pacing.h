#pragma once
// Wall clock pacing (rt/loop/pacing.h): tick k is emitted at its absolute deadline
// start + ⌊k·den·10⁹/num⌋ ns on CLOCK_MONOTONIC, with whatever frame is ready for it.
//   Render thread  skips frames whose tick has passed and aims each frame at the first tick it
//                  can meet given the latency of the last few frames; starts it just in time
//                  (the slowest recent latency + a margin + one period before its deadline), so
//                  that its pose is extrapolated as little as possible. A frame's deadline is
//                  its tick, or, when its exposures are marked on a gate line, its first
//                  exposure's start (a field and half the exposure before the tick when
//                  interlaced): a frame made after it gets no pulse and is not emitted.
//   Output thread  sleeps to each deadline; a tick without its frame is a miss. When it wakes a
//                  whole period late, the lost ticks are counted and skipped, never caught up.

#include <array>
#include <atomic>

#include "rt/loop/pacing.h"

namespace nvs::rt {

class WallPacing final : public RealTimePacing {
  public:
    explicit WallPacing(const PacingContext& ctx) : RealTimePacing(ctx) {}
    double tickTime_s(std::int64_t k) const noexcept override { return ctx_.wall.tickTime_s(k); }
    std::int64_t frameDue(std::int64_t r) noexcept override;
    bool startFrame(std::int64_t r, FrameStart& at) noexcept override;
    bool pastTick(std::int64_t r, std::int64_t now_ns) const noexcept override {
        return now_ns > madeBy_ns(r);
    }
    void frameMade(std::int64_t took_ns) noexcept override;
    bool awaitTick(std::int64_t& k, std::int64_t& now_ns) noexcept override;
    bool onDeadlines() const noexcept override { return true; }
    void tickDone(std::int64_t next) noexcept override {
        outputTick_.store(next, std::memory_order_release);
    }

  private:
    // When frame r must be made: its tick, or its first exposure's start when the exposures
    // are marked on a gate line (the pulse cannot rise before the frame is made).
    std::int64_t madeBy_ns(std::int64_t r) const noexcept {
        return ctx_.wall.deadline_ns(r) - ctx_.markLead_ns;
    }
    std::atomic<std::int64_t> outputTick_{0};  // the tick the output thread is at
    // The last frame latencies (render start → camera done; camera thread), and from them the
    // latency the render thread expects, to aim each frame at a tick it can meet.
    static constexpr int kRecentFrames = 5;
    std::array<std::int64_t, kRecentFrames> recentFrame_ns_{};
    int recentNext_ = 0;
    int recentCount_ = 0;
    std::atomic<std::int64_t> expectedFrame_ns_{0};  // median + 10 % + 0.5 ms: the aim
    std::atomic<std::int64_t> leadFrame_ns_{0};      // max + 25 % + 1 ms + a period: when to start
};

}  // namespace nvs::rt
