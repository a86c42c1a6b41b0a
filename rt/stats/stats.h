#pragma once
// Run statistics (docs/design.md §5): output period, deadline misses, frame (render + camera) time,
// runtime overhead, telemetry-to-output latency. Each histogram is written by one thread
// only and is allocated at setup: recording a sample is an increment, never an allocation.

#include <cstdint>
#include <string>
#include <vector>

namespace nvs::rt {

// Durations in 1 µs bins from 0 to 200 ms; larger values land in an overflow count but the
// exact maximum is kept. Percentiles are the bin's upper edge (error ≤ 1 µs).
class DurationHistogram {
  public:
    static constexpr int kBins = 200'000;
    static constexpr double kBin_s = 1e-6;

    DurationHistogram() : bins_(kBins, 0) {}
    void add(double d_s) noexcept;
    std::int64_t count() const { return count_; }
    double max_s() const { return max_s_; }
    double min_s() const { return count_ > 0 ? min_s_ : 0.0; }
    double mean_s() const { return count_ > 0 ? sum_s_ / static_cast<double>(count_) : 0.0; }
    // q in [0, 1]; 0 when empty.
    double quantile_s(double q) const noexcept;
    // {"n":…,"p50_s":…,"p99_s":…,"max_s":…,"mean_s":…}
    std::string json() const;

  private:
    std::vector<std::uint32_t> bins_;
    std::int64_t count_ = 0;
    std::int64_t overflow_ = 0;
    double sum_s_ = 0.0;
    double max_s_ = 0.0;
    double min_s_ = 1e300;
};

// A deadline miss is a tick whose fresh frame was not ready; the late-frame policy then either
// repeats the previous frame (`repeats`) or sends nothing (`droppedFrames`): every miss is one
// or the other (or a skipped tick). A repeat is not a drop. What became of the frames that
// missed is counted apart: rendered too late (`lateFrames`) or not rendered at all because
// their tick had already passed when the render thread came to them (`skippedRenders`).
struct RunCounters {
    std::int64_t ticks = 0;           // deadlines passed
    std::int64_t framesRendered = 0;  // frames through render + camera
    std::int64_t framesEmitted = 0;   // fresh frames handed to the sinks
    std::int64_t repeats = 0;         // missed ticks that re-sent the previous frame (repeat)
    std::int64_t deadlineMisses = 0;  // ticks whose frame was not ready, or woke > ½ period late
    std::int64_t skippedTicks = 0;    // whole periods lost because the output itself was late
    std::int64_t droppedFrames =
        0;                        // missed ticks on which nothing was sent (drop, or no frame yet)
    std::int64_t lateFrames = 0;  // frames rendered but discarded: their tick had passed
    std::int64_t skippedRenders = 0;  // frames never rendered: their tick had passed already
    std::int64_t sinkErrors = 0;      // failed sink writes (counted per sink in its status)
    std::int64_t sinkQueueDrops = 0;  // frames an output's full queue could not take (per sink)
    std::int64_t outputsFailed = 0;   // outputs that failed (can write nothing more)
    std::int64_t staleFrames = 0;     // frames rendered with stale telemetry
};

struct RunStats {
    RunCounters counters;
    DurationHistogram period;         // between consecutive emissions (wall clock)
    DurationHistogram wakeLate;       // emission start − deadline (wall clock)
    DurationHistogram frameTime;      // render + camera stage per frame
    DurationHistogram overhead;       // loop's own work per frame (excludes stages and sinks)
    DurationHistogram sinkTime;       // handing one frame to every sink (copy into each queue)
    DurationHistogram latency;        // telemetry receive → frame emitted (handed to the sinks)
    DurationHistogram renderLatency;  // render start → frame emitted (fresh frames)
    double elapsed_s = 0.0;
    // Start-up (wall and trigger clocks): how long FrameLoop::start took to make the loop's
    // threads before it took the run clock's origin, and the first frame the camera thread
    // finished (−1: none) with when it did, on the run clock (negative: before tick 0).
    double loopStart_s = 0.0;
    std::int64_t firstFrame = -1;
    double firstFrameMade_s = 0.0;
};

}  // namespace nvs::rt
