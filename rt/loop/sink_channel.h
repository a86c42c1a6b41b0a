#pragma once
// One output's own bounded queue and thread (rt/clock/threads.h: nvs-sink), so that a consumer
// that stalls (a pipe nobody reads) or goes away (EPIPE) holds up only its own output: never
// the frame loop, and never another output (V4L2, GPIO, files).
//
//   output thread   offer(): copies what the sink reads of the frame (SinkInputs: counts,
//                   radiance, metadata) into the next free entry of a ring of preallocated
//                   entries and hands it on — a memcpy, never an allocation, never a wait.
//                   When every entry is still queued the frame is dropped for this sink alone
//                   and counted (`queue drops`). Under the sim clock, where every frame must be
//                   written, offerWait() waits for a free entry instead (until stopped).
//   sink thread     takes entries in order and calls FrameSink::write(); counts what was
//                   written, the errors, and the time from hand-off to written (write_latency).
//                   After a write it asks the sink whether it has failed (a reader gone, a file
//                   abandoned): a failed sink is given nothing more.
//   stopping        finish(): the thread writes what is queued and returns. A write blocked on
//                   a consumer is ended by cancel() (FrameSink::cancel): the loop cancels at
//                   once when the run was interrupted, and otherwise when one write has made
//                   no progress for FrameLoop's drain timeout.
// A direct sink (SinkInputs::direct: the GPIO gate, whose write() never blocks) gets neither
// queue nor thread: offer() calls write() on the output thread.

#include <atomic>
#include <cstdint>
#include <memory>
#include <thread>
#include <vector>

#include "rt/loop/stages.h"
#include "rt/stats/stats.h"
#include "sim/core/image.h"

namespace nvs::rt {

struct SinkChannelCounters {
    std::int64_t offered = 0;     // frames handed to the channel
    std::int64_t written = 0;     // frames the sink wrote
    std::int64_t queueDrops = 0;  // frames dropped because its queue was full
    std::int64_t errors = 0;      // failed writes
    bool failed = false;          // the sink can write nothing more
};

class SinkChannel {
  public:
    static constexpr int kMaxDepth = 64;
    // Setup: allocates `depth` entries (1..kMaxDepth) of what the sink reads.
    SinkChannel(FrameSink& sink, int depth, int width, int height, RenderStage::Outputs images);
    ~SinkChannel();
    SinkChannel(const SinkChannel&) = delete;
    SinkChannel& operator=(const SinkChannel&) = delete;

    FrameSink& sink() const { return sink_; }
    bool direct() const { return direct_; }

    // Starts the sink thread (none for a direct sink).
    void start(bool realtime);
    // Output thread: queues a copy of `f`; false when it was dropped (queue full) or the sink
    // has failed. A direct sink is written here.
    bool offer(const OutputFrame& f) noexcept;
    // Output thread, sim clock: as offer(), but waits for a free entry; false when `stop` was
    // set or the sink failed while waiting.
    bool offerWait(const OutputFrame& f, const std::atomic<bool>& stop) noexcept;
    // Wakes an offerWait() (any thread), e.g. to see a stop request.
    void wake() noexcept;
    // No more frames: the thread writes what is queued and returns.
    void finish() noexcept;
    // Ends a write blocked on the consumer, now and later (FrameSink::cancel).
    void cancel() noexcept;
    bool done() const noexcept { return done_.load(std::memory_order_acquire); }
    // CLOCK_MONOTONIC when the write in progress began; 0 when idle.
    std::int64_t writingSince_ns() const noexcept {
        return writingSince_ns_.load(std::memory_order_acquire);
    }
    void join();

    // Any thread, any time (relaxed snapshots).
    SinkChannelCounters counters() const noexcept;
    bool failed() const noexcept { return failed_.load(std::memory_order_acquire); }
    std::int64_t errors() const noexcept { return errors_.load(std::memory_order_relaxed); }
    // Hand-off → written, per frame (sink thread; complete after join()).
    const DurationHistogram& writeLatency() const { return writeLatency_; }

  private:
    struct Entry {
        FrameMeta meta;
        ImageU16 counts;
        ImageF lpe_pe_s_m2_sr;
        ImageF band_W_m2_sr;
        OutputFrame frame;
        std::int64_t handoff_ns = 0;
    };
    void copyInto(Entry& e, const OutputFrame& f) noexcept;
    void run(bool realtime) noexcept;
    void writeDirect(const OutputFrame& f) noexcept;

    FrameSink& sink_;
    bool direct_;
    bool wantCounts_, wantRadiance_;
    int depth_;
    std::vector<std::unique_ptr<Entry>> entries_;
    // Single producer (output thread), single consumer (sink thread).
    std::atomic<std::uint64_t> head_{0};       // next entry to write (consumer)
    std::atomic<std::uint64_t> tail_{0};       // next entry to fill (producer)
    std::atomic<std::uint32_t> queuedSeq_{0};  // bumped on every push and at finish
    std::atomic<std::uint32_t> freeSeq_{0};    // bumped on every pop, failure and wake
    std::atomic<bool> finishing_{false};
    std::atomic<bool> done_{false};
    std::atomic<bool> failed_{false};
    std::atomic<std::int64_t> writingSince_ns_{0};
    std::atomic<std::int64_t> offered_{0};
    std::atomic<std::int64_t> written_{0};
    std::atomic<std::int64_t> queueDrops_{0};
    std::atomic<std::int64_t> errors_{0};
    DurationHistogram writeLatency_;
    std::thread thread_;
};

}  // namespace nvs::rt
