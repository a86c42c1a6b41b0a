#include "rt/loop/pacing.h"

#include <cmath>

#include "rt/loop/sim_pacing.h"
#include "rt/loop/trigger_pacing.h"
#include "rt/loop/wall_pacing.h"
#include "sim/core/error.h"

namespace nvs::rt {

std::int64_t RealTimePacing::monotonic_ns(double run_s) const noexcept {
    return ctx_.wall.start_ns() + std::llround(run_s * 1e9);
}

void RealTimePacing::stamp(OutputFrame& of, std::int64_t now_ns) noexcept {
    of.emit_s = ctx_.wall.runTime_s(now_ns);
    of.emitMonotonic_ns = now_ns;
    if (lastEmit_ns_ != 0) ctx_.stats.period.add(static_cast<double>(now_ns - lastEmit_ns_) * 1e-9);
    lastEmit_ns_ = now_ns;
}

double RealTimePacing::writtenTime_s(std::int64_t written_ns, double /*emit_s*/) const noexcept {
    return ctx_.wall.runTime_s(written_ns);
}

std::unique_ptr<Pacing> makePacing(ClockKind kind, const PacingContext& ctx, TriggerSource* trigger,
                                   double triggerTimeout_s) {
    switch (kind) {
        case ClockKind::Wall:
            return std::make_unique<WallPacing>(ctx);
        case ClockKind::Trigger:
            if (trigger == nullptr) throw SetupError("the trigger clock needs a trigger input");
            return std::make_unique<TriggerPacing>(ctx, *trigger, triggerTimeout_s);
        case ClockKind::Sim:
            break;
    }
    return std::make_unique<SimPacing>(ctx);
}

}  // namespace nvs::rt
