// Frame clocks, statistics, the synthetic stages and the pipelined loop, checked against what
// they must be by construction: exact tick times, closed-form radiance, cadence under late
// frames.
#include <gtest/gtest.h>

#include <cmath>
#include <thread>

#include "rt/clock/clock.h"
#include "rt/loop/frame_loop.h"
#include "rt/stats/stats.h"
#include "rt/synth/synth.h"

namespace nvs::rt {
namespace {

TEST(FrameRate, NtscRatesAreExactFractions) {
    EXPECT_EQ(FrameRate::fromHz(59.94).num, 60000);
    EXPECT_EQ(FrameRate::fromHz(59.94).den, 1001);
    EXPECT_EQ(FrameRate::fromHz(29.97).num, 30000);
    EXPECT_EQ(FrameRate::fromHz(60.0).num, 60);
    EXPECT_EQ(FrameRate::fromHz(60.0).den, 1);
}

TEST(SimClock, TickTimesAreKTimesDtBitExact) {
    SimClock c(FrameRate{60000, 1001});
    for (std::int64_t k : {0LL, 1LL, 1000LL, 123456789LL}) {
        EXPECT_EQ(c.tickTime_s(k), static_cast<double>(k) * 1001.0 / 60000.0);
    }
}

TEST(WallClock, DeadlinesDoNotAccumulateRounding) {
    WallClock c(FrameRate{60000, 1001});
    c.start(1000);
    // 60000 ticks of 1001/60000 s are exactly 1001 s: no drift from a rounded period.
    EXPECT_EQ(c.deadline_ns(60000) - 1000, 1001LL * 1'000'000'000LL);
    for (std::int64_t k : {0LL, 1LL, 59LL, 60000LL, 10'000'000LL}) {
        EXPECT_EQ(c.tickAt(c.deadline_ns(k)), k);
        EXPECT_EQ(c.tickAt(c.deadline_ns(k) - 1), k - 1 < 0 ? -1 : k - 1);
    }
}

TEST(DurationHistogram, QuantilesOfAKnownSample) {
    DurationHistogram h;
    for (int i = 1; i <= 1000; ++i)
        h.add(i * 1e-5);  // 10 µs … 10 ms uniformly
    EXPECT_EQ(h.count(), 1000);
    EXPECT_NEAR(h.quantile_s(0.5), 500e-5, 1e-6);
    EXPECT_NEAR(h.quantile_s(0.99), 990e-5, 1e-6);
    EXPECT_DOUBLE_EQ(h.max_s(), 1000e-5);
    h.add(5.0);  // beyond the range: overflow, max kept exactly
    EXPECT_DOUBLE_EQ(h.max_s(), 5.0);
    EXPECT_DOUBLE_EQ(h.quantile_s(1.0), 5.0);
}

TEST(TestPattern, BarsHaveTheirClosedFormRadianceAndCountsAreLinear) {
    const double lMax = 2e-4;
    TestPatternRender render(lMax, 0.0);
    LinearCamera camera(lMax, 8);
    ImageF rad(64, 32);
    ImageU16 counts(64, 32);
    FrameRequest req;
    req.platform.yaw_rad = 0.5 * 3.14159265358979;  // a quarter turn
    FrameMeta meta;
    render.render(req, rad.view(), meta);
    camera.expose(req, rad.cview(), counts.view(), meta);
    for (int bar = 0; bar < 8; ++bar) {
        const int x = bar * 8 + 3;
        EXPECT_FLOAT_EQ(rad(x, 5), static_cast<float>(lMax * bar / 7.0)) << bar;
        EXPECT_EQ(counts(x, 5), static_cast<std::uint16_t>(std::lround(255.0 * bar / 7.0)));
    }
    // Pose strip: a quarter of the width lit at L_max/2 (yaw = 90°).
    const int y = 26;
    EXPECT_FLOAT_EQ(rad(14, y), static_cast<float>(lMax / 2));
    EXPECT_FLOAT_EQ(rad(17, y), 0.0f);
    ASSERT_EQ(meta.truthCount, 1);
    EXPECT_EQ(meta.truth[0].id, 1);
    EXPECT_FLOAT_EQ(meta.truth[0].w_px, 4.0f);  // side = h/8
}

// A sink that records which frame went out on which tick.
class RecordingSink final : public FrameSink {
  public:
    const char* name() const noexcept override { return "record"; }
    int write(const OutputFrame& f) noexcept override {
        if (n < kMax) {
            frame[n] = f.meta->frame;
            tick[n] = f.tick;
            repeat[n] = f.repeat;
            mono[n] = f.emitMonotonic_ns;
            ++n;
        }
        return 0;
    }
    int close() noexcept override { return 0; }
    std::string status() const override { return "record"; }
    static constexpr int kMax = 4096;
    std::int64_t frame[kMax] = {}, tick[kMax] = {}, mono[kMax] = {};
    bool repeat[kMax] = {};
    int n = 0;
};

// A render stage that is slow on chosen frames (a late frame).
class SlowRender final : public RenderStage {
  public:
    explicit SlowRender(std::int64_t slowFrame, double delay_s)
        : slow_(slowFrame), delay_(delay_s) {}
    void render(const FrameRequest& req, ImageView<float> r, FrameMeta&) noexcept override {
        r.fill(static_cast<float>(req.frame));
        if (req.frame == slow_) {
            std::this_thread::sleep_for(std::chrono::duration<double>(delay_));
        }
    }

  private:
    std::int64_t slow_;
    double delay_;
};

TEST(FrameLoop, SimClockEmitsEveryFrameInOrder) {
    LoopConfig cfg;
    cfg.rate = FrameRate{60, 1};
    cfg.clock = ClockKind::Sim;
    cfg.frames = 500;
    cfg.width = 16;
    cfg.height = 16;
    HeldPlatform platform(PlatformState{});
    SlowRender render(-1, 0.0);
    LinearCamera camera(1000.0, 16);
    RecordingSink sink;
    FrameLoop loop(cfg, platform, render, camera, {&sink});
    std::vector<std::string> msgs;
    loop.start(msgs);
    loop.join();
    ASSERT_EQ(sink.n, 500);
    for (int i = 0; i < 500; ++i) {
        EXPECT_EQ(sink.frame[i], i);
        EXPECT_EQ(sink.tick[i], i);
    }
    EXPECT_EQ(loop.stats().counters.deadlineMisses, 0);
    EXPECT_EQ(loop.stats().counters.framesEmitted, 500);
}

// Wall clock, 100 Hz, frame 30 takes 35 ms (3.5 periods): the ticks it overlaps are misses,
// the previous frame is repeated, and every emission stays on the absolute grid k·dt.
TEST(FrameLoop, WallClockHoldsCadenceWhenAFrameIsLate) {
    for (LatePolicy policy : {LatePolicy::Repeat, LatePolicy::Drop}) {
        LoopConfig cfg;
        cfg.rate = FrameRate{100, 1};
        cfg.clock = ClockKind::Wall;
        cfg.frames = 80;
        cfg.width = 16;
        cfg.height = 16;
        cfg.latePolicy = policy;
        HeldPlatform platform(PlatformState{});
        SlowRender render(30, 0.035);
        LinearCamera camera(1000.0, 16);
        RecordingSink sink;
        FrameLoop loop(cfg, platform, render, camera, {&sink});
        std::vector<std::string> msgs;
        loop.start(msgs);
        loop.join();
        const RunCounters& c = loop.stats().counters;
        // The render thread works up to two frames ahead, so 35 ms of delay costs 2–4 ticks.
        EXPECT_GE(c.deadlineMisses, 2) << "policy " << static_cast<int>(policy);
        EXPECT_LE(c.deadlineMisses, 5);
        if (policy == LatePolicy::Repeat) {
            EXPECT_EQ(c.repeats, c.deadlineMisses - c.skippedTicks);
        } else {
            EXPECT_EQ(c.repeats, 0);
        }
        // Never drift: every emission lies within its own tick's period on the absolute grid
        // (k·dt from the first), however late frame 30 was; and the last ones are as punctual
        // as the first ones.
        const std::int64_t t0 = sink.mono[0];
        double lateSum_s = 0.0;
        for (int i = 0; i < sink.n; ++i) {
            const double late_s = static_cast<double>(sink.mono[i] - t0) * 1e-9 -
                                  static_cast<double>(sink.tick[i]) * 0.01;
            EXPECT_GE(late_s, -0.001) << i;
            EXPECT_LT(late_s, 0.01) << i;
            if (i >= sink.n - 20) lateSum_s += late_s;
            if (!sink.repeat[i]) {
                EXPECT_EQ(sink.frame[i], sink.tick[i]);
            }
        }
        EXPECT_LT(lateSum_s / 20.0, 0.002);
        // After the late frame the loop is back on fresh frames.
        EXPECT_EQ(sink.frame[sink.n - 1], 79);
    }
}

}  // namespace
}  // namespace nvs::rt
