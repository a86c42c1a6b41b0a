#include "rt/loop/frame_loop.h"

#include <cerrno>

#include "rt/clock/threads.h"

namespace nvs::rt {

FrameLoop::FrameLoop(const LoopConfig& config, PlatformSource& platform, RenderStage& render,
                     CameraStage& camera, std::vector<FrameSink*> sinks)
    : config_(config),
      platform_(platform),
      render_(render),
      camera_(camera),
      sinks_(std::move(sinks)),
      wall_(config.rate),
      sim_(config.rate),
      exposure_s_(config.exposure_s > 0.0 ? config.exposure_s : config.rate.period_s()) {
    for (int i = 0; i < kSlots; ++i) {
        slots_[i].radiance = ImageF(config.width, config.height);
        slots_[i].counts = ImageU16(config.width, config.height);
        free_.push(i);
    }
}

FrameLoop::~FrameLoop() {
    requestStop();
    join();
}

double FrameLoop::tickTime_s(std::int64_t k) const {
    return config_.clock == ClockKind::Wall ? wall_.tickTime_s(k) : sim_.tickTime_s(k);
}

void FrameLoop::start(std::vector<std::string>& messages) {
    if (config_.realtime) {
        std::string msg;
        if (lockMemory(msg) != 0) messages.push_back(msg);
    }
    // Tick 0 is one period away, so frame 0 has a whole period to render.
    wall_.start(monotonicNow_ns() + wall_.deadline_ns(1));
    const bool rt = config_.realtime;
    renderThread_ = std::thread([this, rt] { renderThread(rt); });
    outputThread_ = std::thread([this, rt] { outputThread(rt); });
    // Give the threads a moment to report refused real-time settings.
    if (rt) {
        for (int i = 0; i < 100 && (renderMessage_.empty() || outputMessage_.empty()); ++i)
            std::this_thread::sleep_for(std::chrono::milliseconds(1));
    }
    if (!renderMessage_.empty() && renderMessage_ != "ok") messages.push_back(renderMessage_);
    if (!outputMessage_.empty() && outputMessage_ != "ok" && outputMessage_ != renderMessage_) {
        messages.push_back(outputMessage_);
    }
}

void FrameLoop::requestStop() noexcept {
    stop_.store(true, std::memory_order_release);
    readySeq_.fetch_add(1, std::memory_order_release);
    readySeq_.notify_all();
    freeSeq_.fetch_add(1, std::memory_order_release);
    freeSeq_.notify_all();
}

void FrameLoop::join() {
    if (renderThread_.joinable()) renderThread_.join();
    if (outputThread_.joinable()) outputThread_.join();
    stats_.frameTime = frameTime_;
    stats_.counters.framesRendered = framesRendered_;
    stats_.counters.droppedFrames += renderDropped_;
    renderDropped_ = 0;
    stats_.counters.staleFrames = staleFrames_;
}

// ---- render thread ---------------------------------------------------------------------------

void FrameLoop::renderThread(bool realtime) {
    std::string msg;
    applyThreadSpec(kThreadRender, realtime, msg);
    renderMessage_ = msg.empty() ? "ok" : msg;
    const bool wall = config_.clock == ClockKind::Wall;
    std::int64_t r = 0;
    for (;;) {
        if (stop_.load(std::memory_order_acquire)) break;
        if (config_.frames >= 0 && r >= config_.frames) break;
        if (wall) {
            // A frame whose deadline has passed is worth nothing: skip to the next one due.
            const std::int64_t due = outputTick_.load(std::memory_order_acquire);
            if (r < due) {
                renderDropped_ += due - r;
                live_.dropped.fetch_add(due - r, std::memory_order_relaxed);
                r = due;
                if (config_.frames >= 0 && r >= config_.frames) break;
            }
        }
        int slot = -1;
        while (!free_.pop(slot)) {
            const std::uint32_t seq = freeSeq_.load(std::memory_order_acquire);
            if (free_.peek(slot)) continue;
            if (stop_.load(std::memory_order_acquire)) goto done;
            freeSeq_.wait(seq, std::memory_order_acquire);
        }
        {
            Slot& s = slots_[slot];
            const std::int64_t t0_ns = monotonicNow_ns();
            FrameRequest req;
            req.frame = r;
            req.t_sample_s = tickTime_s(r);
            req.exposure_s = exposure_s_;
            // "Now" for telemetry: the wall clock's reading, or under the sim clock the
            // instant this frame's render nominally starts, one period before its deadline.
            const double now_s =
                wall ? wall_.runTime_s(t0_ns) : (r > 0 ? sim_.tickTime_s(r - 1) : 0.0);
            platform_.sample(req.t_sample_s, now_s, req.platform);
            s.meta.truthCount = 0;
            render_.render(req, s.radiance.view(), s.meta);
            camera_.expose(req, s.radiance.cview(), s.counts.view(), s.meta);
            s.meta.frame = r;
            s.meta.t_sample_s = req.t_sample_s;
            s.meta.exposure_s = req.exposure_s;
            // The camera stage may have changed gain/gate (AGC); keep what it set.
            const double gain = s.meta.platform.gain_V;
            const double gate = s.meta.platform.gate_s;
            const bool cameraSet = s.meta.platform.t_sample_s == req.t_sample_s;
            s.meta.platform = req.platform;
            if (cameraSet) {
                s.meta.platform.gain_V = gain;
                s.meta.platform.gate_s = gate;
            }
            s.frame = r;
            if (req.platform.stale) ++staleFrames_;
            live_.stale.store(req.platform.stale, std::memory_order_relaxed);
            frameTime_.add(static_cast<double>(monotonicNow_ns() - t0_ns) * 1e-9);
        }
        ++framesRendered_;
        ready_.push(slot);
        readySeq_.fetch_add(1, std::memory_order_release);
        readySeq_.notify_all();
        ++r;
    }
done:
    renderDone_.store(true, std::memory_order_release);
    readySeq_.fetch_add(1, std::memory_order_release);
    readySeq_.notify_all();
}

// ---- output thread ---------------------------------------------------------------------------

bool FrameLoop::waitReady(std::int64_t k) noexcept {
    for (;;) {
        const std::uint32_t seq = readySeq_.load(std::memory_order_acquire);
        int slot = -1;
        if (ready_.peek(slot) && slots_[slot].frame >= k) return true;
        if (renderDone_.load(std::memory_order_acquire)) {
            return ready_.peek(slot);  // frames handed over before the end
        }
        if (stop_.load(std::memory_order_acquire)) return false;
        readySeq_.wait(seq, std::memory_order_acquire);
    }
}

void FrameLoop::emit(int slot, std::int64_t tick, bool repeat, std::int64_t now_ns) {
    const Slot& s = slots_[slot];
    const bool wall = config_.clock == ClockKind::Wall;
    OutputFrame of;
    of.meta = &s.meta;
    of.radiance_W_m2_sr = s.radiance.cview();
    of.counts = s.counts.cview();
    of.bits = camera_.bits();
    of.tick = tick;
    of.repeat = repeat;
    of.emit_s = wall ? wall_.runTime_s(now_ns) : sim_.tickTime_s(tick);
    of.emitMonotonic_ns = wall ? now_ns : 0;
    const std::int64_t s0 = monotonicNow_ns();
    for (FrameSink* sink : sinks_) {
        if (sink->write(of) < 0) {
            ++stats_.counters.sinkErrors;
            live_.sinkErrors.fetch_add(1, std::memory_order_relaxed);
            if (config_.sinkErrorPolicy == SinkErrorPolicy::Stop && failure_.empty()) {
                failure_ = "stopping: output '";  // completed at join time
                failure_ += sink->name();
                failure_ += "' failed (sink error policy is stop)";
                stop_.store(true, std::memory_order_release);
            }
        }
    }
    const std::int64_t s1 = monotonicNow_ns();
    stats_.sinkTime.add(static_cast<double>(s1 - s0) * 1e-9);
    if (wall) {
        if (lastEmit_ns_ != 0) stats_.period.add(static_cast<double>(now_ns - lastEmit_ns_) * 1e-9);
        lastEmit_ns_ = now_ns;
    }
    const double rx_s = s.meta.platform.telemetryRx_s;
    if (rx_s >= 0.0) {
        // Telemetry receive → frame emitted (written to every sink).
        const double out_s = wall ? wall_.runTime_s(s1) : of.emit_s;
        stats_.latency.add(out_s - rx_s);
        live_.lastLatency_ns.store(static_cast<std::int64_t>((out_s - rx_s) * 1e9),
                                   std::memory_order_relaxed);
    }
}

void FrameLoop::outputThread(bool realtime) {
    std::string msg;
    applyThreadSpec(kThreadOutput, realtime, msg);
    outputMessage_ = msg.empty() ? "ok" : msg;
    const bool wall = config_.clock == ClockKind::Wall;
    const std::int64_t period_ns = wall_.deadline_ns(1) - wall_.start_ns();
    int held = -1;
    const std::int64_t t_start = monotonicNow_ns();
    std::int64_t k = 0;
    for (; config_.frames < 0 || k < config_.frames; ++k) {
        if (stop_.load(std::memory_order_acquire)) break;
        std::int64_t now_ns = 0;
        if (wall) {
            const std::int64_t deadline = wall_.deadline_ns(k);
            while (WallClock::sleepUntil(deadline) == -EINTR) {
                if (stop_.load(std::memory_order_acquire)) break;
            }
            if (stop_.load(std::memory_order_acquire)) break;
            now_ns = monotonicNow_ns();
            if (now_ns - deadline >= period_ns) {
                // Woke a whole period or more late: those ticks are gone; never catch up by
                // sending frames in a burst.
                const std::int64_t kNow = wall_.tickAt(now_ns);
                stats_.counters.skippedTicks += kNow - k;
                stats_.counters.deadlineMisses += kNow - k;
                live_.misses.fetch_add(kNow - k, std::memory_order_relaxed);
                k = kNow;
                if (config_.frames >= 0 && k >= config_.frames) break;
            }
            stats_.wakeLate.add(static_cast<double>(now_ns - wall_.deadline_ns(k)) * 1e-9);
        } else if (!waitReady(k)) {
            break;
        }
        const std::int64_t w0 = monotonicNow_ns();
        ++stats_.counters.ticks;
        // Take frame k from the ready ring; frames older than k missed their tick.
        int use = -1;
        int slot = -1;
        while (ready_.peek(slot)) {
            if (slots_[slot].frame < k) {
                ready_.pop(slot);
                free_.push(slot);
                ++stats_.counters.droppedFrames;
                live_.dropped.fetch_add(1, std::memory_order_relaxed);
                continue;
            }
            if (slots_[slot].frame == k) {
                ready_.pop(slot);
                use = slot;
            }
            break;
        }
        std::int64_t overhead_ns = monotonicNow_ns() - w0;
        if (use >= 0) {
            if (held >= 0) free_.push(held);
            held = use;
            freeSeq_.fetch_add(1, std::memory_order_release);
            freeSeq_.notify_all();
            emit(held, k, false, wall ? now_ns : 0);
            ++stats_.counters.framesEmitted;
            live_.emitted.fetch_add(1, std::memory_order_relaxed);
        } else if (!wall && renderDone_.load(std::memory_order_acquire)) {
            break;  // the render thread stopped early (stop requested)
        } else {
            ++stats_.counters.deadlineMisses;
            live_.misses.fetch_add(1, std::memory_order_relaxed);
            freeSeq_.fetch_add(1, std::memory_order_release);
            freeSeq_.notify_all();
            if (config_.latePolicy == LatePolicy::Repeat && held >= 0) {
                emit(held, k, true, now_ns);
                ++stats_.counters.repeats;
                live_.repeats.fetch_add(1, std::memory_order_relaxed);
            }
        }
        // The loop's own work on this tick; the sinks' time is measured apart (sinkTime).
        stats_.overhead.add(static_cast<double>(overhead_ns) * 1e-9);
        outputTick_.store(k + 1, std::memory_order_release);
    }
    stats_.elapsed_s = static_cast<double>(monotonicNow_ns() - t_start) * 1e-9;
    // Let the render thread go: nothing more will be taken.
    stop_.store(true, std::memory_order_release);
    freeSeq_.fetch_add(1, std::memory_order_release);
    freeSeq_.notify_all();
    outputDone_.store(true, std::memory_order_release);
}

}  // namespace nvs::rt
