#include "rt/loop/loop_events.h"

#include <cstddef>

namespace nvs::rt {

namespace {

using RunField = std::int64_t RunCounters::*;
using TriggerField = std::int64_t TriggerStats::*;
using LiveField = std::atomic<std::int64_t> LiveCounters::*;

// The counters each event moves by n (empty entries: none), one row per event in LoopEvent's
// order. TicksLost: the ticks passed (`ticks` counts every tick), were skipped, and each is a
// miss. TriggerStall also raises the live "stalled" flag (LoopEvents::count).
struct Moves {
    LoopEvent event;
    RunField run[3];
    TriggerField trigger;
    LiveField live[2];
};
using R = RunCounters;
using T = TriggerStats;
using L = LiveCounters;
constexpr Moves kMoves[] = {
    {LoopEvent::Tick, {&R::ticks}, nullptr, {}},
    {LoopEvent::TicksLost,
     {&R::ticks, &R::skippedTicks, &R::deadlineMisses},
     nullptr,
     {&L::misses}},
    {LoopEvent::FrameEmitted, {&R::framesEmitted}, nullptr, {&L::emitted}},
    {LoopEvent::MissRepeated,
     {&R::deadlineMisses, &R::repeats},
     nullptr,
     {&L::misses, &L::repeats}},
    {LoopEvent::MissDropped,
     {&R::deadlineMisses, &R::droppedFrames},
     nullptr,
     {&L::misses, &L::dropped}},
    {LoopEvent::LateFrame, {&R::lateFrames}, nullptr, {&L::late}},
    {LoopEvent::RenderSkipped, {&R::skippedRenders}, nullptr, {&L::skipped}},
    {LoopEvent::FrameRendered, {&R::framesRendered}, nullptr, {}},
    {LoopEvent::StaleFrame, {&R::staleFrames}, nullptr, {}},
    {LoopEvent::TriggerEdge, {}, &T::edges, {}},
    {LoopEvent::TriggerExtra, {}, &T::extra, {&L::triggerExtra}},
    {LoopEvent::TriggerMissing, {}, &T::missing, {&L::triggerMissing}},
    {LoopEvent::TriggerOverrun, {}, &T::overruns, {}},
    {LoopEvent::TriggerFrame, {}, &T::frames, {}},
    {LoopEvent::TriggerStall, {}, &T::stalls, {}},
    {LoopEvent::TriggerError, {}, &T::errors, {}},
};

constexpr bool rowsInEventOrder() {
    for (std::size_t i = 0; i < std::size(kMoves); ++i)
        if (static_cast<std::size_t>(kMoves[i].event) != i) return false;
    return std::size(kMoves) == static_cast<std::size_t>(LoopEvent::TriggerError) + 1;
}
static_assert(rowsInEventOrder(), "kMoves has one row per LoopEvent, in order");

}  // namespace

void LoopEvents::count(LoopEvent e, std::int64_t n) noexcept {
    const Moves& m = kMoves[static_cast<std::size_t>(e)];
    for (RunField f : m.run)
        if (f != nullptr) run_.*f += n;
    if (m.trigger != nullptr) trigger_.*m.trigger += n;
    for (LiveField f : m.live)
        if (f != nullptr) (live_.*f).fetch_add(n, std::memory_order_relaxed);
    if (e == LoopEvent::TriggerStall) live_.triggerStalled.store(true, std::memory_order_relaxed);
}

}  // namespace nvs::rt
