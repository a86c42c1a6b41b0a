#pragma once
// The frame loop (DESIGN §5): two pipelined threads (rt/clock/threads.h).
//
//   render thread   frame k+1: telemetry → pose at t_{k+1}, render stage, camera stage, into a
//                   free slot; hands the slot to the output thread.
//   output thread   tick k: sleep to deadline k (wall clock) or wait for frame k (sim clock),
//                   emit frame k to every sink, hand the previous slot back.
//
// Three preallocated slots circulate through two single-producer/single-consumer rings
// (free → render → ready → output → free); the output thread keeps the slot it emitted last
// so that it can repeat it. Nothing is allocated and nothing throws after start().
//
// Timing. Frame k samples the world at t_sample_s = t_k = k·dt (its exposure's mid-time) and
// is emitted at deadline k, which is t_k on the run clock: the equipment under test sees the
// world as it is when the frame arrives; the pose is extrapolated by up to one period.
// Late frames (wall clock): when frame k is not ready at deadline k, the tick is a deadline
// miss and, by policy, the previous frame is repeated or nothing is sent. Deadlines are
// absolute (k·dt from the start), so a late frame never shifts later ones: the loop holds its
// cadence. The render thread skips frames whose deadline has already passed; when the output
// thread itself wakes a whole period late, the lost ticks are counted and skipped.
// Under the sim clock nothing is ever late: the output waits for every frame, so two runs are
// identical bit for bit.

#include <atomic>
#include <cstdint>
#include <string>
#include <thread>
#include <vector>

#include "rt/clock/clock.h"
#include "rt/msg/stages.h"
#include "rt/stats/stats.h"
#include "sim/core/image.h"

namespace nvs::rt {

enum class ClockKind { Sim, Wall };
enum class LatePolicy { Repeat, Drop };
enum class SinkErrorPolicy { Count, Stop };

struct LoopConfig {
    FrameRate rate;
    ClockKind clock = ClockKind::Sim;
    std::int64_t frames = -1;  // stop after this many ticks; −1: until stopped
    LatePolicy latePolicy = LatePolicy::Repeat;
    SinkErrorPolicy sinkErrorPolicy = SinkErrorPolicy::Count;
    double exposure_s = 0.0;  // 0: one period
    int width = 320;
    int height = 240;
    bool realtime = false;  // SCHED_FIFO per the thread table, and mlockall
};

// Single-producer single-consumer ring of small integers (slot numbers).
class SlotRing {
  public:
    static constexpr int kCapacity = 8;
    bool push(int v) noexcept {
        const std::uint32_t t = tail_.load(std::memory_order_relaxed);
        if (t - head_.load(std::memory_order_acquire) >= kCapacity) return false;
        items_[t % kCapacity] = v;
        tail_.store(t + 1, std::memory_order_release);
        return true;
    }
    bool peek(int& v) const noexcept {
        const std::uint32_t h = head_.load(std::memory_order_relaxed);
        if (h == tail_.load(std::memory_order_acquire)) return false;
        v = items_[h % kCapacity];
        return true;
    }
    bool pop(int& v) noexcept {
        if (!peek(v)) return false;
        head_.store(head_.load(std::memory_order_relaxed) + 1, std::memory_order_release);
        return true;
    }

  private:
    int items_[kCapacity] = {};
    std::atomic<std::uint32_t> head_{0};
    std::atomic<std::uint32_t> tail_{0};
};

// Numbers the live status line reads while the loop runs (written by the loop threads).
struct LiveCounters {
    std::atomic<std::int64_t> emitted{0};
    std::atomic<std::int64_t> misses{0};
    std::atomic<std::int64_t> repeats{0};
    std::atomic<std::int64_t> dropped{0};
    std::atomic<std::int64_t> sinkErrors{0};
    std::atomic<std::int64_t> lastLatency_ns{-1};
    std::atomic<bool> stale{false};
};

class FrameLoop {
  public:
    // Setup: allocates the slots. The stages and sinks must outlive the loop.
    FrameLoop(const LoopConfig& config, PlatformSource& platform, RenderStage& render,
              CameraStage& camera, std::vector<FrameSink*> sinks);
    ~FrameLoop();
    FrameLoop(const FrameLoop&) = delete;
    FrameLoop& operator=(const FrameLoop&) = delete;

    // Starts both threads. Messages about refused real-time settings go to `messages`.
    void start(std::vector<std::string>& messages);
    // Asks both threads to finish the frame in hand and stop (async-signal-safe: a store).
    void requestStop() noexcept;
    bool finished() const noexcept { return outputDone_.load(std::memory_order_acquire); }
    // Waits for both threads. Statistics are complete after this.
    void join();

    const LiveCounters& live() const { return live_; }
    const RunStats& stats() const { return stats_; }
    // Why the loop stopped early: "" (frame count reached or stop requested) or a message.
    const std::string& failure() const { return failure_; }
    const LoopConfig& config() const { return config_; }
    double tickTime_s(std::int64_t k) const;

  private:
    struct Slot {
        std::int64_t frame = -1;
        FrameMeta meta;
        ImageF radiance;
        ImageU16 counts;
    };
    void renderThread(bool realtime);
    void outputThread(bool realtime);
    void emit(int slot, std::int64_t tick, bool repeat, std::int64_t now_ns);
    bool waitReady(std::int64_t k) noexcept;  // sim clock: until frame k or the end

    LoopConfig config_;
    PlatformSource& platform_;
    RenderStage& render_;
    CameraStage& camera_;
    std::vector<FrameSink*> sinks_;
    WallClock wall_;
    SimClock sim_;
    double exposure_s_;

    static constexpr int kSlots = 3;
    Slot slots_[kSlots];
    SlotRing free_;
    SlotRing ready_;
    std::atomic<std::uint32_t> readySeq_{0};
    std::atomic<std::uint32_t> freeSeq_{0};
    std::atomic<std::int64_t> outputTick_{0};
    std::atomic<bool> stop_{false};
    std::atomic<bool> renderDone_{false};
    std::atomic<bool> outputDone_{false};

    std::thread renderThread_;
    std::thread outputThread_;
    std::string renderMessage_;
    std::string outputMessage_;
    std::string failure_;
    std::int64_t lastEmit_ns_ = 0;

    RunStats stats_;
    // Render-thread statistics, merged into stats_ at join().
    DurationHistogram frameTime_;
    std::int64_t framesRendered_ = 0;
    std::int64_t renderDropped_ = 0;
    std::int64_t staleFrames_ = 0;
    LiveCounters live_;
};

}  // namespace nvs::rt
