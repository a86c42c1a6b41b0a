#include "rt/loop/trigger_pacing.h"

#include <algorithm>
#include <cmath>

namespace nvs::rt {

TriggerPacing::TriggerPacing(const PacingContext& ctx, TriggerSource& trigger, double timeout_s)
    : RealTimePacing(ctx),
      trigger_(trigger),
      timeout_ns_(timeout_s > 0.0 ? static_cast<std::int64_t>(std::llround(timeout_s * 1e9))
                                  : 3 * ctx.period_ns) {}

bool TriggerPacing::startFrame(std::int64_t /*r*/, FrameStart& at) noexcept {
    // The slot is in hand, so the frame starts as soon as its edge comes.
    std::int64_t edge_ns = 0;
    if (!waitEdge(edge_ns)) return false;
    at.start_ns = monotonicNow_ns();
    at.edge_ns = edge_ns;
    // The edge starts the (first) exposure, so t_sample_s = t_edge + e/2; t_k, the last
    // field's, is one field later per further field.
    at.t_k_s = ctx_.wall.runTime_s(edge_ns) + 0.5 * ctx_.exposure_s +
               static_cast<double>(ctx_.fields - 1) * ctx_.field_s;
    at.now_s = ctx_.wall.runTime_s(at.start_ns);
    return true;
}

bool TriggerPacing::awaitTick(std::int64_t& k, std::int64_t& now_ns) noexcept {
    if (!ctx_.ready.waitReady(k)) return false;
    now_ns = monotonicNow_ns();  // emitted as soon as it is ready
    return true;
}

bool TriggerPacing::acceptEdge(std::int64_t t_ns) noexcept {
    ctx_.events.count(LoopEvent::TriggerEdge);
    const std::int64_t period_ns = ctx_.period_ns;
    if (lastEdge_ns_ != 0) {
        const std::int64_t d = t_ns - lastEdge_ns_;
        if (2 * d < period_ns) {
            // Less than half a period after the last good edge: a glitch or a double pulse.
            ctx_.events.count(LoopEvent::TriggerExtra);
            return false;
        }
        // n = round(d/dt) periods since the last good edge: n − 1 edges went missing.
        const std::int64_t n = (2 * d + period_ns) / (2 * period_ns);
        if (n >= 2) ctx_.events.count(LoopEvent::TriggerMissing, n - 1);
        ctx_.trigger.interval.add(static_cast<double>(d) * 1e-9);
    }
    lastEdge_ns_ = t_ns;
    ref_ns_ = t_ns;
    stalled_ = false;
    ctx_.live.triggerStalled.store(false, std::memory_order_relaxed);
    return true;
}

bool TriggerPacing::waitEdge(std::int64_t& edge_ns) noexcept {
    // Wait in short slices so that a stop request is seen within 20 ms.
    const std::int64_t slice_ns = std::min<std::int64_t>(ctx_.period_ns, 20'000'000);
    for (;;) {
        if (ctx_.stop.load(std::memory_order_acquire)) return false;
        std::int64_t t = 0;
        const int rc = trigger_.waitEdge(slice_ns, &t);
        if (rc == 1) {
            if (!acceptEdge(t)) continue;
            // Edges that queued up while the last frame rendered: the newest one starts this
            // frame (the older exposures are over); the others are overruns.
            std::int64_t t2 = 0;
            while (trigger_.waitEdge(0, &t2) == 1) {
                if (acceptEdge(t2)) {
                    ctx_.events.count(LoopEvent::TriggerOverrun);
                    t = t2;
                }
            }
            ctx_.events.count(LoopEvent::TriggerFrame);
            edge_ns = t;
            return true;
        }
        if (rc < 0) {
            // A failing input returns at once: count it and wait a slice before retrying.
            ctx_.events.count(LoopEvent::TriggerError);
            WallClock::sleepUntil(monotonicNow_ns() + slice_ns);
        }
        if (!stalled_ && monotonicNow_ns() - ref_ns_ > timeout_ns_) {
            stalled_ = true;
            ctx_.events.count(LoopEvent::TriggerStall);
        }
    }
}

}  // namespace nvs::rt
