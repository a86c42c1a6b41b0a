#include "rt/loop/wall_pacing.h"

#include <algorithm>
#include <cerrno>

namespace nvs::rt {

std::int64_t WallPacing::frameDue(std::int64_t r) noexcept {
    // A frame whose deadline has passed is worth nothing: skip to the next one due. And when
    // frames take longer than a period, the next one due cannot be on time either: aim at the
    // first tick a frame started now can still meet, given how long frames take now (so a slow
    // scene shows fewer fresh frames, each at its own tick, instead of none).
    std::int64_t due = outputTick_.load(std::memory_order_acquire);
    const std::int64_t expected_ns = expectedFrame_ns_.load(std::memory_order_relaxed);
    if (expected_ns > 0) {
        due =
            std::max(due, ctx_.wall.tickAt(monotonicNow_ns() + expected_ns + ctx_.markLead_ns) + 1);
    }
    if (r >= due) return r;
    ctx_.events.count(LoopEvent::RenderSkipped, due - r);
    return due;
}

bool WallPacing::startFrame(std::int64_t r, FrameStart& at) noexcept {
    // Just in time: a frame started long before its deadline would show a pose extrapolated
    // that much further ahead and older telemetry. Start it when the slowest recent frames
    // would still make it with a period to spare (the slots bound how far ahead it can be
    // anyway), in slices so that a stop is seen.
    const std::int64_t lead_ns = leadFrame_ns_.load(std::memory_order_relaxed);
    if (lead_ns > 0) {
        const std::int64_t startAt = madeBy_ns(r) - lead_ns;
        for (std::int64_t now = monotonicNow_ns(); now < startAt; now = monotonicNow_ns()) {
            if (ctx_.stop.load(std::memory_order_acquire)) return false;
            WallClock::sleepUntil(std::min(startAt, now + 20'000'000));
        }
    }
    at.start_ns = monotonicNow_ns();
    at.edge_ns = 0;
    at.t_k_s = ctx_.wall.tickTime_s(r);
    at.now_s = ctx_.wall.runTime_s(at.start_ns);
    return true;
}

void WallPacing::frameMade(std::int64_t took_ns) noexcept {
    // The median of the last few frame latencies (a single slow frame does not move it), with
    // a margin for the output thread's wake-up and the sinks.
    recentFrame_ns_[recentNext_] = took_ns;
    recentNext_ = (recentNext_ + 1) % kRecentFrames;
    recentCount_ = std::min(recentCount_ + 1, kRecentFrames);
    std::array<std::int64_t, kRecentFrames> t = recentFrame_ns_;
    for (int i = 1; i < recentCount_; ++i)  // insertion sort of at most kRecentFrames values
        for (int j = i; j > 0 && t[j - 1] > t[j]; --j)
            std::swap(t[j - 1], t[j]);
    const std::int64_t median_ns = t[recentCount_ / 2];
    expectedFrame_ns_.store(median_ns + median_ns / 10 + 500'000, std::memory_order_relaxed);
    // When to start a frame: early enough for the slowest of them plus a quarter, 1 ms and one
    // period (slack for a busy machine's scheduling and an occasional slower frame).
    const std::int64_t max_ns = t[recentCount_ - 1];
    leadFrame_ns_.store(max_ns + max_ns / 4 + 1'000'000 + ctx_.period_ns,
                        std::memory_order_relaxed);
}

bool WallPacing::awaitTick(std::int64_t& k, std::int64_t& now_ns) noexcept {
    const std::int64_t deadline = ctx_.wall.deadline_ns(k);
    while (WallClock::sleepUntil(deadline) == -EINTR) {
        if (ctx_.stop.load(std::memory_order_acquire)) break;
    }
    if (ctx_.stop.load(std::memory_order_acquire)) return false;
    now_ns = monotonicNow_ns();
    if (now_ns - deadline >= ctx_.period_ns) {
        // Woke a whole period or more late: those ticks are gone; never catch up by sending
        // frames in a burst.
        const std::int64_t kNow = ctx_.wall.tickAt(now_ns);
        ctx_.events.count(LoopEvent::TicksLost, kNow - k);
        k = kNow;
        if (ctx_.frames >= 0 && k >= ctx_.frames) return false;
    }
    ctx_.stats.wakeLate.add(static_cast<double>(now_ns - ctx_.wall.deadline_ns(k)) * 1e-9);
    return true;
}

}  // namespace nvs::rt
