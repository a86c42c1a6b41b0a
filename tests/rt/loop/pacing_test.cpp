// The loop's counters and its pacing variants, each checked alone: every event moves exactly the
// counters it names, and each clock's pacing gives the times docs/runtime.md states.
#include "rt/loop/pacing.h"

#include <gtest/gtest.h>

#include <atomic>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>

#include "rt/loop/loop_events.h"
#include "sim/core/error.h"

namespace nvs::rt {
namespace {

struct Counts {
    RunCounters run;
    TriggerStats trigger;
    LiveCounters live;
    LoopEvents events{run, trigger, live};
};

TEST(LoopEvents, EveryTickIsEmittedRepeatedDroppedOrLost) {
    Counts c;
    c.events.count(LoopEvent::Tick);
    c.events.count(LoopEvent::FrameEmitted);
    c.events.count(LoopEvent::Tick);
    c.events.count(LoopEvent::MissRepeated);
    c.events.count(LoopEvent::Tick);
    c.events.count(LoopEvent::MissDropped);
    c.events.count(LoopEvent::TicksLost, 3);
    EXPECT_EQ(c.run.ticks, 6);
    EXPECT_EQ(c.run.ticks,
              c.run.framesEmitted + c.run.repeats + c.run.droppedFrames + c.run.skippedTicks);
    EXPECT_EQ(c.run.deadlineMisses, 5);
    EXPECT_EQ(c.run.repeats, c.run.deadlineMisses - c.run.skippedTicks - c.run.droppedFrames);
    EXPECT_EQ(c.live.misses.load(), 5);
    EXPECT_EQ(c.live.emitted.load(), 1);
    EXPECT_EQ(c.live.repeats.load(), 1);
    EXPECT_EQ(c.live.dropped.load(), 1);
}

TEST(LoopEvents, RenderCameraAndTriggerEventsMoveTheirOwnCounters) {
    Counts c;
    c.events.count(LoopEvent::RenderSkipped, 2);
    c.events.count(LoopEvent::LateFrame);
    c.events.count(LoopEvent::FrameRendered);
    c.events.count(LoopEvent::StaleFrame);
    EXPECT_EQ(c.run.skippedRenders, 2);
    EXPECT_EQ(c.live.skipped.load(), 2);
    EXPECT_EQ(c.run.lateFrames, 1);
    EXPECT_EQ(c.live.late.load(), 1);
    EXPECT_EQ(c.run.framesRendered, 1);
    EXPECT_EQ(c.run.staleFrames, 1);
    EXPECT_EQ(c.run.ticks, 0);
    for (LoopEvent e : {LoopEvent::TriggerEdge, LoopEvent::TriggerExtra, LoopEvent::TriggerOverrun,
                        LoopEvent::TriggerFrame, LoopEvent::TriggerStall, LoopEvent::TriggerError})
        c.events.count(e);
    c.events.count(LoopEvent::TriggerMissing, 4);
    EXPECT_EQ(c.trigger.edges, 1);
    EXPECT_EQ(c.trigger.extra, 1);
    EXPECT_EQ(c.live.triggerExtra.load(), 1);
    EXPECT_EQ(c.trigger.missing, 4);
    EXPECT_EQ(c.live.triggerMissing.load(), 4);
    EXPECT_EQ(c.trigger.overruns, 1);
    EXPECT_EQ(c.trigger.frames, 1);
    EXPECT_EQ(c.trigger.stalls, 1);
    EXPECT_TRUE(c.live.triggerStalled.load());
    EXPECT_EQ(c.trigger.errors, 1);
}

// Frames "ready" up to a given index.
class FakeReady final : public ReadyFrames {
  public:
    bool waitReady(std::int64_t k) noexcept override { return k < readyUpTo; }
    std::int64_t readyUpTo = 0;
};

// Edges given in advance, each returned once, then timeouts.
class FakeTrigger final : public TriggerSource {
  public:
    const char* name() const noexcept override { return "fake"; }
    int waitEdge(std::int64_t /*timeout_ns*/, std::int64_t* t) noexcept override {
        if (edges.empty()) return 0;
        *t = edges.front();
        edges.pop_front();
        return 1;
    }
    std::string status() const override { return "fake"; }
    std::deque<std::int64_t> edges;
};

struct Loop {
    FrameRate rate{100, 1};  // 10 ms
    WallClock wall{rate};
    SimClock sim{rate};
    std::atomic<bool> stop{false};
    FakeReady ready;
    RunStats stats;
    TriggerStats trigger;
    LiveCounters live;
    LoopEvents events{stats.counters, trigger, live};
    PacingContext ctx() {
        return PacingContext{wall, sim, stop,       ready, events, stats, trigger,
                             live, 10,  10'000'000, 0.004, 1,      0.01};
    }
};

TEST(Pacing, SimTimesAreComputedAndEveryFrameReachesEveryOutput) {
    Loop l;
    const std::unique_ptr<Pacing> p = makePacing(ClockKind::Sim, l.ctx(), nullptr, 0.0);
    FrameStart at;
    ASSERT_TRUE(p->startFrame(3, at));
    EXPECT_EQ(at.t_k_s, l.sim.tickTime_s(3));
    EXPECT_EQ(at.now_s, l.sim.tickTime_s(2));  // the tick before: the render's nominal start
    EXPECT_EQ(at.edge_ns, 0);
    EXPECT_TRUE(p->lossless());
    EXPECT_FALSE(p->onDeadlines());
    EXPECT_EQ(p->monotonic_ns(1.0), 0);
    l.ready.readyUpTo = 2;
    std::int64_t k = 1, now_ns = -1;
    EXPECT_TRUE(p->awaitTick(k, now_ns));
    EXPECT_EQ(now_ns, 0);
    k = 2;
    EXPECT_FALSE(p->awaitTick(k, now_ns));
    OutputFrame of;
    of.tick = 7;
    p->stamp(of, 12345);
    EXPECT_EQ(of.emit_s, l.sim.tickTime_s(7));
    EXPECT_EQ(of.emitMonotonic_ns, 0);
    EXPECT_EQ(l.stats.period.count(), 0);
}

TEST(Pacing, WallSkipsFramesWhoseTickHasPassedAndStampsRealTimes) {
    Loop l;
    l.wall.start(monotonicNow_ns() + 10'000'000);
    const std::unique_ptr<Pacing> p = makePacing(ClockKind::Wall, l.ctx(), nullptr, 0.0);
    EXPECT_TRUE(p->onDeadlines());
    EXPECT_FALSE(p->lossless());
    EXPECT_EQ(p->frameDue(0), 0);
    p->tickDone(4);  // the output is at tick 4: frames 1 to 3 are too late to render
    EXPECT_EQ(p->frameDue(1), 4);
    EXPECT_EQ(l.stats.counters.skippedRenders, 3);
    EXPECT_EQ(p->tickTime_s(5), l.wall.tickTime_s(5));
    EXPECT_EQ(p->monotonic_ns(0.5), l.wall.start_ns() + 500'000'000);
    OutputFrame of;
    p->stamp(of, l.wall.start_ns() + 20'000'000);
    p->stamp(of, l.wall.start_ns() + 30'000'000);
    EXPECT_DOUBLE_EQ(of.emit_s, 0.03);
    EXPECT_EQ(of.emitMonotonic_ns, l.wall.start_ns() + 30'000'000);
    EXPECT_EQ(l.stats.period.count(), 1);
}

TEST(Pacing, TriggerClassifiesEdgesAgainstTheNominalPeriod) {
    Loop l;
    EXPECT_THROW(makePacing(ClockKind::Trigger, l.ctx(), nullptr, 0.0), SetupError);
    FakeTrigger trig;
    const std::int64_t t0 = 1'000'000'000;
    l.wall.start(t0);
    // A good edge, a glitch 2 ms later, then one three periods on (two missing).
    trig.edges = {t0 + 10'000'000, t0 + 12'000'000, t0 + 40'000'000};
    const std::unique_ptr<Pacing> p = makePacing(ClockKind::Trigger, l.ctx(), &trig, 0.0);
    p->started(t0);
    FrameStart at;
    ASSERT_TRUE(p->startFrame(0, at));
    // All three queued: the newest good one starts the frame, the first is an overrun.
    EXPECT_EQ(at.edge_ns, t0 + 40'000'000);
    EXPECT_DOUBLE_EQ(at.t_k_s, 0.04 + 0.5 * 0.004);
    EXPECT_EQ(l.trigger.edges, 3);
    EXPECT_EQ(l.trigger.extra, 1);
    EXPECT_EQ(l.trigger.missing, 2);
    EXPECT_EQ(l.trigger.overruns, 1);
    EXPECT_EQ(l.trigger.frames, 1);
    EXPECT_EQ(l.trigger.interval.count(), 1);
    EXPECT_FALSE(p->onDeadlines());
    EXPECT_FALSE(p->lossless());
}

}  // namespace
}  // namespace nvs::rt
