#pragma once
// Trigger clock pacing (rt/loop/pacing.h): frames locked to rising edges from the equipment
// under test. Each good edge at t_e (CLOCK_MONOTONIC, on the wall clock's run clock) starts one
// exposure: the frame's (first field's) t_sample_s = t_e + e/2, and the frame is emitted as
// soon as it is ready (no deadline, never repeated). Edges are checked against the nominal
// period dt: an edge less than dt/2 after the previous one is an extra edge (counted,
// ignored); an interval of n·dt with n ≥ 2 counts n − 1 missing edges; edges that queued up
// while a frame rendered are overruns (counted; the newest one is used). No edge for the
// timeout (default three periods) marks the trigger stalled until the next edge.

#include "rt/loop/pacing.h"

namespace nvs::rt {

class TriggerPacing final : public RealTimePacing {
  public:
    // `timeout_s`: no edge for this long is a stall; 0: three periods.
    TriggerPacing(const PacingContext& ctx, TriggerSource& trigger, double timeout_s);
    double tickTime_s(std::int64_t k) const noexcept override { return ctx_.sim.tickTime_s(k); }
    void started(std::int64_t now_ns) noexcept override { ref_ns_ = now_ns; }
    bool startFrame(std::int64_t r, FrameStart& at) noexcept override;
    bool awaitTick(std::int64_t& k, std::int64_t& now_ns) noexcept override;

  private:
    bool waitEdge(std::int64_t& edge_ns) noexcept;  // the next good edge; false when stopping
    bool acceptEdge(std::int64_t t_ns) noexcept;    // classifies one edge; false: extra
    TriggerSource& trigger_;
    std::int64_t timeout_ns_;
    std::int64_t lastEdge_ns_ = 0;
    std::int64_t ref_ns_ = 0;  // last good edge, or the start: stall reference
    bool stalled_ = false;
};

}  // namespace nvs::rt
