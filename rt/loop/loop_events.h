#pragma once
// The frame loop's counters and the events that move them (docs/runtime.md, "Statistics").
// Every count the loop keeps goes through LoopEvents::count, whose table (loop_events.cpp) is
// the one place that maps an event to the run counters (`--stats`, RunCounters), the trigger
// counters (TriggerStats) and the live status line (LiveCounters) it bumps. Each event is counted
// by one thread (noted below), and each counter is moved by the events of one thread only, so no
// counter is written by two threads.

#include <atomic>
#include <cstdint>

#include "rt/stats/stats.h"

namespace nvs::rt {

// Trigger-clock counters (render thread) and edge → emission latency (output thread); read
// after join().
struct TriggerStats {
    std::int64_t edges = 0;      // rising edges read
    std::int64_t frames = 0;     // edges that started a frame
    std::int64_t missing = 0;    // edges absent from the nominal cadence
    std::int64_t extra = 0;      // edges less than half a period after the previous one
    std::int64_t overruns = 0;   // good edges superseded while a frame was rendering
    std::int64_t stalls = 0;     // times the trigger went silent for the timeout
    std::int64_t errors = 0;     // failed waits on the trigger input
    DurationHistogram interval;  // between consecutive good edges
    DurationHistogram latency;   // edge → frame written to every sink
};

// Numbers the live status line reads while the loop runs (written by the loop threads).
struct LiveCounters {
    std::atomic<std::int64_t> emitted{0};
    std::atomic<std::int64_t> misses{0};
    std::atomic<std::int64_t> repeats{0};
    std::atomic<std::int64_t> dropped{0};  // missed ticks on which nothing was sent
    std::atomic<std::int64_t> late{0};     // frames rendered but discarded: their tick had passed
    std::atomic<std::int64_t> skipped{0};  // frames not rendered: their tick had already passed
    std::atomic<std::int64_t> sinkErrors{0};
    std::atomic<std::int64_t> queueDrops{0};     // frames a full output queue could not take
    std::atomic<std::int64_t> outputsFailed{0};  // outputs that can write nothing more
    std::atomic<std::int64_t> lastLatency_ns{-1};
    std::atomic<bool> stale{false};
    // Trigger clock.
    std::atomic<bool> triggerStalled{false};
    std::atomic<std::int64_t> triggerMissing{0};
    std::atomic<std::int64_t> triggerExtra{0};
};

enum class LoopEvent {
    // Output thread.
    Tick,          // a tick passed, whatever it sent
    TicksLost,     // ticks gone while the output thread itself woke late: passed, skipped, missed
    FrameEmitted,  // a fresh frame handed to the sinks
    MissRepeated,  // a tick without its frame; the previous frame was sent again
    MissDropped,   // a tick without its frame; nothing was sent
    LateFrame,     // a frame rendered after its tick had passed, discarded
    // Render thread.
    RenderSkipped,  // frames not rendered: their tick had already passed
    // Camera thread.
    FrameRendered,  // a frame through render and camera
    StaleFrame,     // a frame rendered with stale telemetry
    // Render thread, trigger clock.
    TriggerEdge,     // a rising edge read
    TriggerExtra,    // an edge less than half a period after the last good one (ignored)
    TriggerMissing,  // edges absent from the nominal cadence
    TriggerOverrun,  // a good edge superseded while a frame rendered
    TriggerFrame,    // an edge that started a frame
    TriggerStall,    // the trigger went silent for the timeout (stalled until the next edge)
    TriggerError,    // a failed wait on the trigger input
};

class LoopEvents {
  public:
    LoopEvents(RunCounters& run, TriggerStats& trigger, LiveCounters& live) noexcept
        : run_(run), trigger_(trigger), live_(live) {}
    // Counts `n` events of kind `e` in every counter that event moves.
    void count(LoopEvent e, std::int64_t n = 1) noexcept;

  private:
    RunCounters& run_;
    TriggerStats& trigger_;
    LiveCounters& live_;
};

}  // namespace nvs::rt
