#include "rt/run/timeline.h"

namespace nvs::rt {

void TimelineSource::sample(double t_sample_s, double now_s, PlatformState& out) noexcept {
    inner_->sample(t_sample_s, now_s, out);
    for (const TimelineStep& s : steps_) {
        if (s.t_s > t_sample_s) break;
        out.lampMask = (out.lampMask | s.lampSet) & ~s.lampClear;
        if (s.gain_V) out.gain_V = *s.gain_V;
        if (s.agc) out.agc = *s.agc;
        if (s.gate_s) out.gate_s = *s.gate_s;
        if (s.gateMode) out.gateMode = *s.gateMode;
    }
}

}  // namespace nvs::rt
