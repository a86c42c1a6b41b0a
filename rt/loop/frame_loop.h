#pragma once
// The frame loop (docs/design.md §5): three pipelined threads (rt/clock/threads.h).
//
//   render thread   frame k+2: (trigger clock: wait for its edge) telemetry → pose at each
//                   exposure's mid-time, render stage, into a free slot; hands the slot on.
//   camera thread   frame k+1: camera stage per exposure, in frame order (its state — phosphor,
//                   AGC — runs on from frame to frame); tells the exposure observers (GPIO gate
//                   pulse) when each exposure is; hands the slot to the output thread.
//   output thread   tick k: sleep to deadline k (wall clock) or wait for frame k (sim and
//                   trigger clocks), emit frame k to every sink, hand the previous slot back.
//
// Render and camera run at once on different frames, so a frame costs the longer of the two
// in throughput and their sum in latency. Five preallocated slots circulate through three
// single-producer/single-consumer rings (free → render → rendered → camera → ready → output →
// free); the output thread keeps the slot it emitted last so that it can repeat it. Nothing is
// allocated and nothing throws after start().
//
// Timing. Frame k samples the world at t_sample_s = t_k = k·dt (its exposure's mid-time) and
// is emitted at deadline k, which is t_k on the run clock: the equipment under test sees the
// world as it is when the frame arrives; the pose is extrapolated by up to one period.
// Late frames (wall clock): when frame k is not ready at deadline k, the tick is a deadline
// miss and, by policy, the previous frame is repeated or nothing is sent. Deadlines are
// absolute (k·dt from the start), so a late frame never shifts later ones: the loop holds its
// cadence. The render thread skips frames whose deadline has already passed, and aims each frame
// at the first tick it can meet given the latency of the last few frames; when the output
// thread itself wakes a whole period late, the lost ticks are counted and skipped.
// Under the sim clock nothing is ever late: the output waits for every frame, so two runs are
// identical bit for bit.
//
// Scan (docs/design.md §5 pacing modes). dt is the period of the emitted frames (frame_rate_hz).
//   Progressive   one exposure per frame: t_sample_s = t_k, exposure [t_k − e/2, t_k + e/2]
//                 (e = exposure_s, default dt). A field-scan camera stage run this way counts
//                 each frame as one field and weaves its own video: that is the field-rate
//                 interlaced mode (59.94 Hz out, each frame the latest two fields).
//   Interlaced    frame-rate interlaced output: each frame is woven from two fields of period
//                 T_f = dt/2, each rendered and exposed at its own time,
//                     field f ∈ {0, 1}:  t_f = t_k − (1 − f)·T_f   (default e = T_f),
//                 field 0 on the even rows, field 1 on the odd rows (top field first, as
//                 sim/sensor's video stage numbers fields; bottom first: the other way round). The
//                 render and camera stages are called once per field, in field order, in the same
//                 slot: field 0 straight into the slot, field 1 into the slot's field buffer whose
//                 rows are then copied over. The loop itself stays one tick per output frame, so
//                 pacing, repeats, statistics and the output thread do not change. A frame is
//                 complete when its second field is, so its t_sample_s is t_k, as in progressive
//                 scan.
//
// Trigger clock (ClockKind::Trigger): frames are locked to rising edges from the equipment
// under test (LoopConfig::trigger, e.g. a GPIO input); each frame is emitted as soon as it is
// ready (rt/loop/trigger_pacing.h: the sample time and how edges are checked). Latency edge →
// frame written to every sink is a histogram (TriggerStats::latency).
//
// Pacing. The loop asks one Pacing object (rt/loop/pacing.h; SimPacing, WallPacing and
// TriggerPacing, chosen by LoopConfig::clock) when to start each frame, what it samples, when
// each tick is emitted and how the emission is stamped: the threads below hold no clock-specific
// branch. Counting. Every counter (RunCounters, TriggerStats, LiveCounters) is moved through
// one LoopEvent (rt/loop/loop_events.h), which alone maps an event to the counters it bumps.
//
// Commanded and applied. FrameMeta::platform is the platform state as commanded (the request's);
// FrameMeta::field[f] is what the camera stage applied to each exposure (CameraStage::expose
// fills it: with AGC the camera chooses its gain). The exposure observers get the applied gate.
//
// Sink workers. A sink that implements SinkWorker (the GPIO gate pulse) gets a thread of the
// thread table (nvs-gpio) from start() to join(): drivers start no thread themselves.
//
// Outputs. Every sink has its own bounded queue and thread (rt/loop/sink_channel.h): at its tick
// the output thread copies the frame into each sink's queue and goes on; a sink whose queue is
// full loses that frame alone (counted as its queue drops). So a consumer that stalls or dies
// delays neither the loop nor any other output. Under the sim clock, where every frame must
// reach every output, the output thread waits for room instead. A sink that has failed (its
// reader went away, its file was abandoned) is given nothing more; when every output has
// failed the run stops with failure() "every output failed". Emission is this hand-off: the
// period, latency and trigger statistics are taken there; each sink's hand-off → written time
// is its write_latency. join() lets each sink write what is queued; a write blocked on its
// consumer is cancelled at once when the run was stopped by requestStop() (SIGINT), else
// after kDrainStall_s without progress.

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "rt/clock/clock.h"
#include "rt/loop/loop_events.h"
#include "rt/loop/pacing.h"
#include "rt/loop/sink_channel.h"
#include "rt/loop/stages.h"
#include "rt/stats/stats.h"
#include "sim/core/image.h"

namespace nvs::rt {

enum class ScanKind { Progressive, Interlaced };
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
    ScanKind scan = ScanKind::Progressive;
    bool topFieldFirst = true;  // interlaced: field 0 on the even rows (else on the odd rows)
    // Interlaced: each field's render fills only the rows its camera reads out, the other rows
    // holding the previous field's radiance (FrameRequest::rowParity); every row after a gap.
    bool fieldRowsOnly = false;
    TriggerSource* trigger = nullptr;  // ClockKind::Trigger: the edges (outlives the loop)
    double triggerTimeout_s = 0.0;     // no edge for this long: stalled; 0: three periods
    int sinkQueueFrames = 8;           // frames each output's queue holds (1..64)
    // A rig's channel (docs/fusion.md): its faults, drawn per frame from faultSeed (the same
    // on every run). Skew: every exposure this much late on the rig's time line (t_sample_s
    // and the gate pulses; with the wall clock the frames are emitted that much late too).
    double skew_s = 0.0;
    double stampJitter_s = 0.0;    // rms of the noise on the reported stamps (RigMeta)
    double dropProbability = 0.0;  // frames made but never sent
    std::uint64_t faultSeed = 0;
};

// When a frame's exposures lie (the Timing and Scan paragraphs above): its exposures (fields),
// the field period, the exposure (0 asked: one frame progressive, one field interlaced), and how
// long before the frame's tick its first exposure starts: half the exposure, and a field more
// when interlaced.
struct ExposureTiming {
    int fields = 1;
    double field_s = 0.0;
    double exposure_s = 0.0;
    double firstLead_s = 0.0;
};
ExposureTiming exposureTiming(FrameRate rate, ScanKind scan, double exposure_s) noexcept;

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

class FrameLoop final : private ReadyFrames {
  public:
    // Setup: allocates the slots. The stages and sinks must outlive the loop.
    FrameLoop(const LoopConfig& config, PlatformSource& platform, RenderStage& render,
              CameraStage& camera, std::vector<FrameSink*> sinks);
    ~FrameLoop();
    FrameLoop(const FrameLoop&) = delete;
    FrameLoop& operator=(const FrameLoop&) = delete;

    // Starts the sink workers and the loop's threads. Messages about refused real-time settings go
    // to `messages`. The same as prepare() then go(0).
    void start(std::vector<std::string>& messages);
    // The two halves of start(), for a rig whose channels share one origin: prepare() makes
    // the threads, which wait; go() takes the run clock's origin, frame 0's tick, at origin_ns
    // on CLOCK_MONOTONIC (the skew added), or 0: originLead_ns() from now.
    void prepare(std::vector<std::string>& messages);
    void go(std::int64_t origin_ns);
    // How far ahead of go() the origin lies at least: a period and frame 0's first exposure's
    // lead, so that frame 0 has a whole period to be made.
    std::int64_t originLead_ns() const noexcept { return period_ns_ + firstExposureLead_ns_; }
    // Asks both threads to finish the frame in hand and stop (async-signal-safe: a store).
    void requestStop() noexcept;
    bool finished() const noexcept { return outputDone_.load(std::memory_order_acquire); }
    // Waits for the loop's threads, then stops and joins the sink workers (the work they
    // were given is finished). Statistics are complete after this.
    void join();

    const LiveCounters& live() const { return live_; }
    const RunStats& stats() const { return stats_; }
    // Why the loop stopped early: "" (frame count reached or stop requested) or a message.
    const std::string& failure() const { return failure_; }
    const LoopConfig& config() const { return config_; }
    double tickTime_s(std::int64_t k) const;
    // The run clock's origin and deadlines on CLOCK_MONOTONIC (wall and trigger clocks).
    const WallClock& wallClock() const { return wall_; }
    const TriggerStats& triggerStats() const { return trigger_; }
    // Frames a rig's drop fault kept from the outputs (after join()).
    std::int64_t faultDrops() const { return faultDrops_; }
    // Exposure time of one frame (progressive) or field (interlaced) [s].
    double exposure_s() const { return exposure_s_; }
    // Each sink's queue and thread, in the order of the sinks given (counters any time; the
    // write latency after join()).
    const SinkChannel& channel(std::size_t i) const { return *channels_[i]; }
    std::size_t channelCount() const { return channels_.size(); }
    // True when the loop was stopped by requestStop() (SIGINT, SIGTERM, a fatal input).
    bool interrupted() const noexcept { return interrupted_.load(std::memory_order_acquire); }
    // Drain at join(): a write that makes no progress for this long is cancelled.
    static constexpr double kDrainStall_s = 1.0;

  private:
    struct Slot {
        std::int64_t frame = -1;
        FrameMeta meta;
        // The render stage's images (those its outputs() names are allocated).
        ImageF lpe_pe_s_m2_sr;
        ImageF band_W_m2_sr;
        ImageU16 counts;
        // Render → camera: each exposure's request; interlaced: field 1's images and meta.
        FrameRequest request[kMaxFields];
        ImageF fieldLpe_pe_s_m2_sr;
        ImageF fieldBand_W_m2_sr;
        FrameMeta fieldMeta;
        std::int64_t start_ns = 0;  // when the render of this frame began (CLOCK_MONOTONIC)
        std::int64_t edge_ns = 0;   // trigger clock: the edge that started it
        bool late = false;          // made after its deadline (wall clock): dropped, no gate pulse
    };
    void renderThread(bool realtime);
    void cameraThread(bool realtime);
    void outputThread(bool realtime);
    // Render thread: a free slot (false when stopping).
    bool takeFreeSlot(int& slot) noexcept;
    // Render thread: samples the pose and renders frame r (its fields) into slot s, as `at` says.
    void renderFrame(Slot& s, std::int64_t r, const FrameStart& at) noexcept;
    // Camera thread: the next rendered slot (false when no more will come).
    bool takeRendered(int& slot) noexcept;
    // Camera thread: exposes the fields rendered into slot s, weaves them, schedules the
    // exposures.
    void exposeFrame(Slot& s) noexcept;
    void scheduleExposure(const Slot& s, int field, double gate_s) noexcept;
    void weaveFields(Slot& s) noexcept;  // interlaced: field 1's rows into the slot
    // Output thread: until frame k (or a later one) is ready or the end (ReadyFrames).
    bool waitReady(std::int64_t k) noexcept override;
    // Output thread: tick k, emitted at now_ns; `held` is the slot kept to repeat. False when
    // the ticks end with the frames.
    bool outputTick(std::int64_t k, std::int64_t now_ns, int& held);
    int takeReady(std::int64_t k) noexcept;  // frame k's slot, or −1 (late frames discarded)
    void missTick(std::int64_t k, std::int64_t now_ns, int held);  // by the late-frame policy
    void emit(int slot, std::int64_t tick, bool repeat, std::int64_t now_ns);
    // A rig's injected faults for frame k: dropped (true), and the jitter of its stamps.
    bool faultDrop(std::int64_t k) const noexcept;
    double faultJitter_s(std::int64_t k) const noexcept;
    void startWorkers();            // one thread per sink worker (start)
    void joinWorkers();             // stops them and waits (join)
    void drainChannels();           // join: what is queued is written
    void checkChannels() noexcept;  // output thread: errors, failures, policy
    static void notify(std::atomic<std::uint32_t>& seq) noexcept;  // a ring changed

    LoopConfig config_;
    PlatformSource& platform_;
    RenderStage& render_;
    CameraStage& camera_;
    std::vector<FrameSink*> sinks_;
    std::vector<std::unique_ptr<SinkChannel>> channels_;
    WallClock wall_;
    SimClock sim_;
    double exposure_s_;
    int fields_;      // exposures per frame: 1 progressive, 2 interlaced
    double field_s_;  // field period (interlaced) [s]
    // How long before its tick a frame's first exposure starts: half the exposure, and a field
    // more when interlaced [ns] (the origin's placement; a gate line's frame deadline).
    std::int64_t firstExposureLead_ns_ = 0;
    std::int64_t period_ns_;
    std::vector<ExposureObserver*> observers_;
    std::vector<SinkWorker*> workers_;
    std::vector<std::thread> workerThreads_;
    // Interlaced: the second field's counts (camera thread).
    ImageU16 fieldCounts_;

    // One slot with the output (kept to repeat), one rendering, one in the camera, and two
    // made ahead of their ticks.
    static constexpr int kSlots = 5;
    Slot slots_[kSlots];
    SlotRing free_;
    SlotRing rendered_;
    SlotRing ready_;
    std::atomic<std::uint32_t> renderedSeq_{0};
    std::atomic<std::uint32_t> readySeq_{0};
    std::atomic<std::uint32_t> freeSeq_{0};
    std::atomic<bool> stop_{false};
    std::atomic<bool> interrupted_{false};
    std::atomic<bool> renderFinished_{false};  // the render thread will hand over no more
    std::atomic<bool> framesDone_{false};      // the camera thread will hand over no more
    std::atomic<bool> outputDone_{false};

    std::thread renderThread_;
    std::thread cameraThread_;
    std::thread outputThread_;
    // Each loop thread's report on its real-time settings: written once by that thread, then
    // posted (messagesPosted_, release); start() reads them after all kLoopThreads posts.
    static constexpr int kLoopThreads = 3;
    std::string renderMessage_;
    std::string cameraMessage_;
    std::string outputMessage_;
    std::atomic<int> messagesPosted_{0};
    void postMessage() noexcept;
    // Set once the run clock's origin is taken (start), or by requestStop: until then the
    // loop's threads, already made, wait in awaitGo().
    std::atomic<bool> go_{false};
    std::int64_t prepared_ns_ = 0;  // when prepare() was called
    void awaitGo() noexcept;
    std::string failure_;

    RunStats stats_;
    std::int64_t lastRendered_ = -2;  // frame index last rendered (render thread)
    std::int64_t faultDropped_ = 0;   // frames dropped by the fault since the last emitted
    std::int64_t faultDrops_ = 0;     // in all (output thread; read after join)
    // Trigger clock (render thread, except trigger_.latency: output thread).
    TriggerStats trigger_;
    LiveCounters live_;
    // Every count goes through events_ (rt/loop/loop_events.h).
    LoopEvents events_{stats_.counters, trigger_, live_};
    // When frames start and ticks are emitted (rt/loop/pacing.h; set up by the constructor).
    std::unique_ptr<Pacing> pacing_;
};

}  // namespace nvs::rt
