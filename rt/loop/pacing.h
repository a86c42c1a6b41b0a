#pragma once
// Pacing (docs/runtime.md, "Clocks and pacing"): when the frame loop starts each frame, what
// time it samples the world at, when each tick is emitted and how its emission is stamped. One
// interface, one variant per clock, chosen once at setup (makePacing):
//
//   SimPacing      (sim_pacing.h)      computed times; every tick waits for its frame and every
//                                      frame reaches every output: runs agree bit for bit.
//   WallPacing     (wall_pacing.h)     absolute deadlines on CLOCK_MONOTONIC; a frame whose tick
//                                      has passed is skipped, the others aimed at a tick they
//                                      can meet and started just in time.
//   TriggerPacing  (trigger_pacing.h)  each frame starts at a rising edge of the trigger input
//                                      and is emitted as soon as it is ready.
//
// The loop's threads call it a few times per frame (never per row or pixel): one virtual call
// each. Nothing here allocates or throws after setup.

#include <atomic>
#include <cstdint>
#include <memory>

#include "rt/clock/clock.h"
#include "rt/loop/loop_events.h"
#include "rt/loop/stages.h"
#include "rt/stats/stats.h"

namespace nvs::rt {

enum class ClockKind { Sim, Wall, Trigger };

// When frame r's render starts and what it samples.
struct FrameStart {
    double t_k_s = 0.0;         // the frame's (last field's) exposure mid-time, run clock [s]
    double now_s = 0.0;         // "now" for telemetry, run clock [s]
    std::int64_t start_ns = 0;  // CLOCK_MONOTONIC when its render begins
    std::int64_t edge_ns = 0;   // trigger clock: the edge that started it (else 0)
};

// The loop's side of the output thread's wait for a frame (FrameLoop implements it).
class ReadyFrames {
  public:
    // Waits until frame k (or a later one) is ready, or the render and camera threads have
    // finished; false when nothing more will come.
    virtual bool waitReady(std::int64_t k) noexcept = 0;

  protected:
    ~ReadyFrames() = default;
};

// What a pacing reads and writes of the loop it paces (each outlives the pacing).
struct PacingContext {
    WallClock& wall;  // the run clock's origin (FrameLoop::start) and deadlines
    const SimClock& sim;
    const std::atomic<bool>& stop;  // waits end soon after it is set
    ReadyFrames& ready;
    LoopEvents& events;
    RunStats& stats;        // output thread: wakeLate, period
    TriggerStats& trigger;  // render thread: interval
    LiveCounters& live;
    std::int64_t frames = -1;  // ticks in the run; −1: until stopped
    std::int64_t period_ns = 0;
    double exposure_s = 0.0;  // one frame's or field's
    int fields = 1;           // exposures per frame
    double field_s = 0.0;     // field period [s]
    // Exposures marked on a gate line (an exposure observer): frame r's first exposure starts
    // this long before its tick, and the frame must be made by then, since its pulse rises
    // there (0: no observer, the tick is the frame's deadline).
    std::int64_t markLead_ns = 0;
};

class Pacing {
  public:
    virtual ~Pacing() = default;
    // Run-clock time of tick k [s].
    virtual double tickTime_s(std::int64_t k) const noexcept = 0;
    // FrameLoop::start, once the run clock is started at `now_ns` (frame 0's first exposure
    // one period later).
    virtual void started(std::int64_t /*now_ns*/) noexcept {}

    // Render thread: the frame to render next, r or a later one (frames skipped are counted).
    virtual std::int64_t frameDue(std::int64_t r) noexcept { return r; }
    // Render thread, with a free slot in hand: waits until frame r should start and says when
    // it samples the world; false when the loop is stopping.
    virtual bool startFrame(std::int64_t r, FrameStart& at) noexcept = 0;
    // Camera thread, frame r made at `now_ns`: true when its deadline has passed on a deadline
    // clock (its tick, or its first exposure's start when exposures are marked: markLead_ns),
    // so that the output thread will drop it (never emitted) and its exposures are not marked
    // on the gate line.
    virtual bool pastTick(std::int64_t /*r*/, std::int64_t /*now_ns*/) const noexcept {
        return false;
    }
    // Camera thread: a frame was done `took_ns` after its render began.
    virtual void frameMade(std::int64_t /*took_ns*/) noexcept {}
    // Camera thread: an exposure start (run clock) on CLOCK_MONOTONIC, for the exposure
    // observers; 0 where the run clock is not real time.
    virtual std::int64_t monotonic_ns(double run_s) const noexcept = 0;

    // Output thread: waits for tick k; may move k past ticks the output thread lost. `now_ns`:
    // the real emission instant (0 where times are computed). False: the run is over.
    virtual bool awaitTick(std::int64_t& k, std::int64_t& now_ns) noexcept = 0;
    // True when ticks come on deadlines, so that a tick without its frame is a miss; false
    // when each tick waits for its frame, so that the ticks end with the frames.
    virtual bool onDeadlines() const noexcept { return false; }
    // True when every frame must reach every output (the output thread waits for room).
    virtual bool lossless() const noexcept { return false; }
    // Output thread: stamps a frame emitted on of.tick at `now_ns` (emit_s, emitMonotonic_ns)
    // and records the emission period.
    virtual void stamp(OutputFrame& of, std::int64_t now_ns) noexcept = 0;
    // Run-clock time at which a frame stamped `emit_s` was written, at `written_ns`.
    virtual double writtenTime_s(std::int64_t written_ns, double emit_s) const noexcept = 0;
    // Output thread: tick k is over; `next` is the next tick.
    virtual void tickDone(std::int64_t /*next*/) noexcept {}
};

// Wall and trigger clocks: emissions and exposures at real instants on the run clock.
class RealTimePacing : public Pacing {
  public:
    explicit RealTimePacing(const PacingContext& ctx) : ctx_(ctx) {}
    std::int64_t monotonic_ns(double run_s) const noexcept override;
    void stamp(OutputFrame& of, std::int64_t now_ns) noexcept override;
    double writtenTime_s(std::int64_t written_ns, double emit_s) const noexcept override;

  protected:
    PacingContext ctx_;

  private:
    std::int64_t lastEmit_ns_ = 0;
};

// The pacing of `kind`. Setup: throws SetupError for a trigger clock without a trigger input.
// `trigger` and `triggerTimeout_s` (0: three periods) are the trigger clock's.
std::unique_ptr<Pacing> makePacing(ClockKind kind, const PacingContext& ctx, TriggerSource* trigger,
                                   double triggerTimeout_s);

}  // namespace nvs::rt
