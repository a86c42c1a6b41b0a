#include "rt/loop/sim_pacing.h"

namespace nvs::rt {

bool SimPacing::startFrame(std::int64_t r, FrameStart& at) noexcept {
    at.start_ns = monotonicNow_ns();
    at.edge_ns = 0;
    at.t_k_s = ctx_.sim.tickTime_s(r);
    // "Now" for telemetry: the instant this frame's render nominally starts, one period before
    // its deadline.
    at.now_s = r > 0 ? ctx_.sim.tickTime_s(r - 1) : 0.0;
    return true;
}

bool SimPacing::awaitTick(std::int64_t& k, std::int64_t& now_ns) noexcept {
    now_ns = 0;
    return ctx_.ready.waitReady(k);
}

void SimPacing::stamp(OutputFrame& of, std::int64_t /*now_ns*/) noexcept {
    of.emit_s = ctx_.sim.tickTime_s(of.tick);
    of.emitMonotonic_ns = 0;
}

}  // namespace nvs::rt
