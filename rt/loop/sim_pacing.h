#pragma once
// Sim clock pacing (rt/loop/pacing.h): nothing sleeps and nothing is late. Frame r samples the
// world at t_r = r·dt, its telemetry "now" is the tick before (its render's nominal start), the
// output waits for every frame and every output takes every frame, and the emission is stamped
// with its tick's time: two runs agree bit for bit.

#include "rt/loop/pacing.h"

namespace nvs::rt {

class SimPacing final : public Pacing {
  public:
    explicit SimPacing(const PacingContext& ctx) : ctx_(ctx) {}
    double tickTime_s(std::int64_t k) const noexcept override { return ctx_.sim.tickTime_s(k); }
    bool startFrame(std::int64_t r, FrameStart& at) noexcept override;
    std::int64_t monotonic_ns(double /*run_s*/) const noexcept override { return 0; }
    bool awaitTick(std::int64_t& k, std::int64_t& now_ns) noexcept override;
    bool lossless() const noexcept override { return true; }
    void stamp(OutputFrame& of, std::int64_t now_ns) noexcept override;
    double writtenTime_s(std::int64_t /*written_ns*/, double emit_s) const noexcept override {
        return emit_s;
    }

  private:
    PacingContext ctx_;
};

}  // namespace nvs::rt
