#pragma once
// The scenario's [[event]] timeline as a PlatformSource decorator: after the wrapped source
// (telemetry, or the held scenario platform) has produced the state at t_sample_s, every event
// with t_s ≤ t_sample_s is applied in time order — lamps switched, gain, AGC, gate changed — so
// an event holds until a later one (or a later telemetry value of a field no event touches).
// Events are resolved to lamp bits at setup; sample() allocates nothing.

#include <cstdint>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rt/compose/scenario.h"
#include "rt/loop/stages.h"

namespace nvs::rt {

struct TimelineStep {
    double t_s = 0.0;
    std::uint32_t lampSet = 0, lampClear = 0;
    std::optional<double> gain_V;
    std::optional<bool> agc;
    std::optional<double> gate_s;
    std::optional<msg::GateMode> gateMode;
};

class TimelineSource final : public PlatformSource {
  public:
    TimelineSource(std::unique_ptr<PlatformSource> inner, std::vector<TimelineStep> steps)
        : inner_(std::move(inner)), steps_(std::move(steps)) {}

    void sample(double t_sample_s, double now_s, PlatformState& out) noexcept override;
    std::string status() const override { return inner_->status(); }
    bool failed() const noexcept override { return inner_->failed(); }

  private:
    std::unique_ptr<PlatformSource> inner_;
    std::vector<TimelineStep> steps_;
};

// Resolves the scenario's events; `lampIndex(name)` gives a lamp's index or −1 (then the event's
// file:line is named in the SetupError).
template <typename LampIndex>
std::vector<TimelineStep> resolveTimeline(const Scenario& sc, LampIndex&& lampIndex) {
    std::vector<TimelineStep> steps;
    for (const TimelineEvent& e : sc.events) {
        TimelineStep s;
        s.t_s = e.t_s;
        if (e.lamp) {
            const int i = lampIndex(*e.lamp);
            if (i < 0 || i >= 32)
                throw SetupError(e.loc, "unknown lamp '" + *e.lamp + "' in the scene");
            (e.lampOn ? s.lampSet : s.lampClear) = 1u << i;
        }
        s.gain_V = e.gain_V;
        s.agc = e.agc;
        s.gate_s = e.gate_s;
        s.gateMode = e.gateMode;
        steps.push_back(s);
    }
    return steps;
}

}  // namespace nvs::rt
