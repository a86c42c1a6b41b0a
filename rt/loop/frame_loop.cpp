#include "rt/loop/frame_loop.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstring>

#include "rt/clock/threads.h"
#include "sim/core/error.h"

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
      fields_(config.scan == ScanKind::Interlaced ? 2 : 1),
      field_s_(config.rate.period_s() / (config.scan == ScanKind::Interlaced ? 2.0 : 1.0)),
      period_ns_(WallClock(config.rate).deadline_ns(1)) {
    // Default exposure: one frame (progressive) or one field (interlaced).
    exposure_s_ = config.exposure_s > 0.0 ? config.exposure_s : field_s_;
    if (config.clock == ClockKind::Trigger && config.trigger == nullptr) {
        throw SetupError("the trigger clock needs a trigger input");
    }
    // Each slot holds the images the render stage fills, each in its own unit.
    const RenderStage::Outputs out = render.outputs();
    const auto image = [&](bool wanted) {
        return wanted ? ImageF(config.width, config.height) : ImageF();
    };
    for (int i = 0; i < kSlots; ++i) {
        Slot& sl = slots_[i];
        sl.lpe_pe_s_m2_sr = image(out.lpe_pe_s_m2_sr);
        sl.band_W_m2_sr = image(out.band_W_m2_sr);
        sl.counts = ImageU16(config.width, config.height);
        sl.fieldLpe_pe_s_m2_sr = image(fields_ == 2 && out.lpe_pe_s_m2_sr);
        sl.fieldBand_W_m2_sr = image(fields_ == 2 && out.band_W_m2_sr);
        free_.push(i);
    }
    if (fields_ == 2) fieldCounts_ = ImageU16(config.width, config.height);
    for (FrameSink* sink : sinks_) {
        if (auto* o = dynamic_cast<ExposureObserver*>(sink)) observers_.push_back(o);
        if (auto* w = dynamic_cast<SinkWorker*>(sink)) workers_.push_back(w);
        // Each output's own queue, holding copies of what it reads (allocated now).
        channels_.push_back(std::make_unique<SinkChannel>(*sink, config.sinkQueueFrames,
                                                          config.width, config.height, out));
    }
    // Stalled: no edge for the timeout (default three nominal periods).
    triggerTimeout_ns_ =
        config.triggerTimeout_s > 0.0
            ? static_cast<std::int64_t>(std::llround(config.triggerTimeout_s * 1e9))
            : 3 * period_ns_;
}

FrameLoop::~FrameLoop() {
    requestStop();
    join();
}

double FrameLoop::tickTime_s(std::int64_t k) const {
    return config_.clock == ClockKind::Wall ? wall_.tickTime_s(k) : sim_.tickTime_s(k);
}

void FrameLoop::startWorkers() {
    // Sink workers first, so that the first exposure scheduled finds its worker running. Real
    // time as the table says when asked; a refusal is the one the loop's threads report.
    const bool rt = config_.realtime;
    for (SinkWorker* w : workers_) {
        workerThreads_.emplace_back([w, rt] {
            std::string ignored;
            applyThreadSpec(kThreadGpio, rt, ignored);
            w->runWorker();
        });
    }
}

void FrameLoop::joinWorkers() {
    for (SinkWorker* w : workers_)
        w->stopWorker();
    for (std::thread& t : workerThreads_)
        if (t.joinable()) t.join();
}

void FrameLoop::start(std::vector<std::string>& messages) {
    startWorkers();
    for (auto& ch : channels_)
        ch->start(config_.realtime);
    if (config_.realtime) {
        std::string msg;
        if (lockMemory(msg) != 0) messages.push_back(msg);
    }
    // Tick 0 is one period away, so frame 0 has a whole period to render.
    const std::int64_t now_ns = monotonicNow_ns();
    wall_.start(now_ns + wall_.deadline_ns(1));
    triggerRef_ns_ = now_ns;
    const bool rt = config_.realtime;
    renderThread_ = std::thread([this, rt] { renderThread(rt); });
    cameraThread_ = std::thread([this, rt] { cameraThread(rt); });
    outputThread_ = std::thread([this, rt] { outputThread(rt); });
    // Collect what each thread said about its real-time settings. Each thread writes its
    // message first thing and never again, then posts it (release); waiting here for all
    // three posts (acquire) makes the strings safe to read. The wait is a few microseconds:
    // the threads post before their first frame.
    for (int n = messagesPosted_.load(std::memory_order_acquire); n < kLoopThreads;
         n = messagesPosted_.load(std::memory_order_acquire))
        messagesPosted_.wait(n, std::memory_order_acquire);
    for (const std::string* m : {&renderMessage_, &cameraMessage_, &outputMessage_}) {
        if (!m->empty() && *m != "ok" &&
            std::find(messages.begin(), messages.end(), *m) == messages.end()) {
            messages.push_back(*m);
        }
    }
}

void FrameLoop::postMessage() noexcept {
    messagesPosted_.fetch_add(1, std::memory_order_release);
    messagesPosted_.notify_all();
}

void FrameLoop::requestStop() noexcept {
    interrupted_.store(true, std::memory_order_release);
    stop_.store(true, std::memory_order_release);
    for (auto& ch : channels_)
        ch->wake();  // an output thread waiting for room (sim clock) sees the stop
    readySeq_.fetch_add(1, std::memory_order_release);
    readySeq_.notify_all();
    freeSeq_.fetch_add(1, std::memory_order_release);
    freeSeq_.notify_all();
    renderedSeq_.fetch_add(1, std::memory_order_release);
    renderedSeq_.notify_all();
}

void FrameLoop::join() {
    if (renderThread_.joinable()) renderThread_.join();
    if (cameraThread_.joinable()) cameraThread_.join();
    if (outputThread_.joinable()) outputThread_.join();
    drainChannels();
    joinWorkers();
    stats_.frameTime = frameTime_;
    stats_.counters.framesRendered = framesRendered_;
    stats_.counters.skippedRenders = renderSkipped_;
    stats_.counters.staleFrames = staleFrames_;
    stats_.counters.sinkErrors = 0;
    stats_.counters.sinkQueueDrops = 0;
    stats_.counters.outputsFailed = 0;
    for (const auto& ch : channels_) {
        const SinkChannelCounters c = ch->counters();
        stats_.counters.sinkErrors += c.errors;
        stats_.counters.sinkQueueDrops += c.queueDrops;
        stats_.counters.outputsFailed += c.failed ? 1 : 0;
    }
}

void FrameLoop::drainChannels() {
    // Each sink writes what is still queued. A write blocked on its consumer (a pipe nobody
    // reads) is cancelled: at once when the run was interrupted, else once it has made no
    // progress for kDrainStall_s, so that stopping never waits on a consumer.
    for (auto& ch : channels_)
        ch->finish();
    const auto stall_ns = static_cast<std::int64_t>(kDrainStall_s * 1e9);
    bool cancelled = false;
    for (;;) {
        bool all = true;
        const std::int64_t now = monotonicNow_ns();
        const bool stopNow = interrupted() && !cancelled;
        for (auto& ch : channels_) {
            if (ch->direct() || ch->done()) continue;
            all = false;
            const std::int64_t since = ch->writingSince_ns();
            if (stopNow || (since != 0 && now - since > stall_ns)) ch->cancel();
        }
        cancelled = cancelled || stopNow;
        if (all) break;
        WallClock::sleepUntil(now + 5'000'000);
    }
    for (auto& ch : channels_)
        ch->join();
}

void FrameLoop::checkChannels() noexcept {
    std::int64_t errors = 0, drops = 0;
    std::size_t failed = 0;
    const SinkChannel* firstError = nullptr;
    for (const auto& ch : channels_) {
        const SinkChannelCounters c = ch->counters();
        errors += c.errors;
        drops += c.queueDrops;
        failed += c.failed ? 1 : 0;
        if (c.errors > 0 && firstError == nullptr) firstError = ch.get();
    }
    live_.sinkErrors.store(errors, std::memory_order_relaxed);
    live_.queueDrops.store(drops, std::memory_order_relaxed);
    live_.outputsFailed.store(static_cast<std::int64_t>(failed), std::memory_order_relaxed);
    if (!failure_.empty()) return;
    // The messages are built once, when the run stops.
    if (config_.sinkErrorPolicy == SinkErrorPolicy::Stop && firstError != nullptr) {
        failure_ = "stopping: output '";
        failure_ += firstError->sink().name();
        failure_ += "' failed (sink error policy is stop)";
        stop_.store(true, std::memory_order_release);
    } else if (!channels_.empty() && failed == channels_.size()) {
        failure_ = "stopping: every output failed";
        stop_.store(true, std::memory_order_release);
    }
}

// ---- render thread ---------------------------------------------------------------------------

void FrameLoop::renderFrame(Slot& s, std::int64_t r, double t_k, double now_s) noexcept {
    for (int f = 0; f < fields_; ++f) {
        // Field f of an interlaced frame: t_f = t_k − (1 − f)·T_f; progressive: t_k.
        const double t_f = t_k - static_cast<double>(fields_ - 1 - f) * field_s_;
        // Field 0 (or the whole frame) into the slot's images; field 1 into its field buffers.
        const RadianceTarget out =
            f == 0 ? RadianceTarget{s.lpe_pe_s_m2_sr.view(), s.band_W_m2_sr.view()}
                   : RadianceTarget{s.fieldLpe_pe_s_m2_sr.view(), s.fieldBand_W_m2_sr.view()};
        FrameMeta& m = f == 0 ? s.meta : s.fieldMeta;
        FrameRequest& req = s.request[f];
        req = FrameRequest{};
        req.frame = r;
        req.t_sample_s = t_f;
        req.exposure_s = exposure_s_;
        // A field's own rows when the one before it was rendered just before (its rows hold
        // the other parity one field ago); every row at the start and after a skipped frame.
        const bool follows = f == 1 || r == lastRendered_ + 1;
        req.rowParity = fields_ == 2 && config_.fieldRowsOnly && follows
                            ? f ^ (config_.topFieldFirst ? 0 : 1)
                            : -1;
        platform_.sample(t_f, now_s, req.platform);
        m.truthCount = 0;
        render_.render(req, out, m);
    }
    s.frame = r;
    lastRendered_ = r;
}

void FrameLoop::exposeFrame(Slot& s) noexcept {
    const bool realClock = config_.clock != ClockKind::Sim;
    const std::int64_t r = s.frame;
    bool stale = false;
    for (int f = 0; f < fields_; ++f) {
        const FrameRequest& req = s.request[f];
        const double t_f = req.t_sample_s;
        const RadianceFrame in =
            f == 0 ? RadianceFrame{s.lpe_pe_s_m2_sr.cview(), s.band_W_m2_sr.cview()}
                   : RadianceFrame{s.fieldLpe_pe_s_m2_sr.cview(), s.fieldBand_W_m2_sr.cview()};
        ImageView<std::uint16_t> counts = f == 0 ? s.counts.view() : fieldCounts_.view();
        FrameMeta& m = f == 0 ? s.meta : s.fieldMeta;
        // What the camera applies starts as what was commanded; a camera with its own gain
        // or gate control (AGC, autogate) overwrites it.
        FieldMeta& applied = s.meta.field[f];
        applied = FieldMeta{t_f, req.platform.gain_V, req.platform.gate_s};
        camera_.expose(req, in, counts, applied);
        applied.t_sample_s = t_f;
        m.frame = r;
        m.t_sample_s = t_f;
        m.exposure_s = exposure_s_;
        m.platform = req.platform;  // as commanded
        stale = stale || req.platform.stale;
        // The exposure on the loop's timeline, for the gate pulse: it is scheduled now, while
        // the frame is made ahead of its emission.
        if (!observers_.empty()) {
            ExposureWindow w;
            w.frame = r;
            w.field = f;
            w.t_sample_s = t_f;
            w.start_s = t_f - 0.5 * exposure_s_;
            w.exposure_s = exposure_s_;
            w.gate_s = applied.gate_s;
            w.startMonotonic_ns = realClock ? wall_.start_ns() + std::llround(w.start_s * 1e9) : 0;
            for (ExposureObserver* o : observers_)
                o->exposureScheduled(w);
        }
    }
    if (fields_ == 2) {
        // Weave: field 1's rows (odd, top field first). The frame is described by field 1, which
        // completes it (messages.h); field[0] keeps the first field's own exposure.
        const std::size_t radBytes = static_cast<std::size_t>(config_.width) * sizeof(float);
        const std::size_t cntBytes =
            static_cast<std::size_t>(config_.width) * sizeof(std::uint16_t);
        const bool lpe = !s.lpe_pe_s_m2_sr.empty();
        const bool band = !s.band_W_m2_sr.empty();
        for (int y = config_.topFieldFirst ? 1 : 0; y < config_.height; y += 2) {
            if (lpe) std::memcpy(s.lpe_pe_s_m2_sr.row(y), s.fieldLpe_pe_s_m2_sr.row(y), radBytes);
            if (band) std::memcpy(s.band_W_m2_sr.row(y), s.fieldBand_W_m2_sr.row(y), radBytes);
            std::memcpy(s.counts.view().row(y), fieldCounts_.cview().row(y), cntBytes);
        }
        s.meta.t_sample_s = s.fieldMeta.t_sample_s;
        s.meta.platform = s.fieldMeta.platform;
        s.meta.truthCount = s.fieldMeta.truthCount;
        for (int i = 0; i < s.fieldMeta.truthCount && i < kMaxTruthBoxes; ++i)
            s.meta.truth[i] = s.fieldMeta.truth[i];
    }
    s.meta.fieldCount = fields_;
    s.meta.triggerEdge_ns = s.edge_ns;
    if (stale) ++staleFrames_;
    live_.stale.store(stale, std::memory_order_relaxed);
}

bool FrameLoop::acceptEdge(std::int64_t t_ns) noexcept {
    ++trigger_.edges;
    if (lastEdge_ns_ != 0) {
        const std::int64_t d = t_ns - lastEdge_ns_;
        if (2 * d < period_ns_) {
            // Less than half a period after the last good edge: a glitch or a double pulse.
            ++trigger_.extra;
            live_.triggerExtra.fetch_add(1, std::memory_order_relaxed);
            return false;
        }
        // n = round(d/dt) periods since the last good edge: n − 1 edges went missing.
        const std::int64_t n = (2 * d + period_ns_) / (2 * period_ns_);
        if (n >= 2) {
            trigger_.missing += n - 1;
            live_.triggerMissing.fetch_add(n - 1, std::memory_order_relaxed);
        }
        trigger_.interval.add(static_cast<double>(d) * 1e-9);
    }
    lastEdge_ns_ = t_ns;
    triggerRef_ns_ = t_ns;
    stalled_ = false;
    live_.triggerStalled.store(false, std::memory_order_relaxed);
    return true;
}

bool FrameLoop::waitTrigger(std::int64_t& edge_ns) noexcept {
    // Wait in short slices so that a stop request is seen within 20 ms.
    const std::int64_t slice_ns = std::min<std::int64_t>(period_ns_, 20'000'000);
    TriggerSource& trig = *config_.trigger;
    for (;;) {
        if (stop_.load(std::memory_order_acquire)) return false;
        std::int64_t t = 0;
        const int rc = trig.waitEdge(slice_ns, &t);
        if (rc == 1) {
            if (!acceptEdge(t)) continue;
            // Edges that queued up while the last frame rendered: the newest one starts this
            // frame (the older exposures are over); the others are overruns.
            std::int64_t t2 = 0;
            while (trig.waitEdge(0, &t2) == 1) {
                if (acceptEdge(t2)) {
                    ++trigger_.overruns;
                    t = t2;
                }
            }
            ++trigger_.frames;
            edge_ns = t;
            return true;
        }
        if (rc < 0) {
            // A failing input returns at once: count it and wait a slice before retrying.
            ++trigger_.errors;
            WallClock::sleepUntil(monotonicNow_ns() + slice_ns);
        }
        if (!stalled_ && monotonicNow_ns() - triggerRef_ns_ > triggerTimeout_ns_) {
            stalled_ = true;
            ++trigger_.stalls;
            live_.triggerStalled.store(true, std::memory_order_relaxed);
        }
    }
}

void FrameLoop::noteFrameLatency(std::int64_t took_ns) noexcept {
    // The median of the last few frame latencies (a single slow frame does not move it), with
    // a margin for the output thread's wake-up and the sinks.
    recentFrame_ns_[recentNext_] = took_ns;
    recentNext_ = (recentNext_ + 1) % kRecentFrames;
    recentCount_ = std::min(recentCount_ + 1, kRecentFrames);
    std::array<std::int64_t, kRecentFrames> t = recentFrame_ns_;
    for (int i = 1; i < recentCount_; ++i)  // insertion sort of at most kRecentFrames values
        for (int j = i; j > 0 && t[j - 1] > t[j]; --j)
            std::swap(t[j - 1], t[j]);
    const std::int64_t median_ns = t[recentCount_ / 2];
    expectedFrame_ns_.store(median_ns + median_ns / 10 + 500'000, std::memory_order_relaxed);
    // When to start a frame: early enough for the slowest of them plus a quarter, 1 ms and one
    // period (slack for a busy machine's scheduling and an occasional slower frame).
    const std::int64_t max_ns = t[recentCount_ - 1];
    leadFrame_ns_.store(max_ns + max_ns / 4 + 1'000'000 + period_ns_, std::memory_order_relaxed);
}

void FrameLoop::renderThread(bool realtime) {
    std::string msg;
    applyThreadSpec(kThreadRender, realtime, msg);
    renderMessage_ = msg.empty() ? "ok" : msg;
    postMessage();
    const bool wall = config_.clock == ClockKind::Wall;
    const bool trig = config_.clock == ClockKind::Trigger;
    std::int64_t r = 0;
    for (;;) {
        if (stop_.load(std::memory_order_acquire)) break;
        if (config_.frames >= 0 && r >= config_.frames) break;
        if (wall) {
            // A frame whose deadline has passed is worth nothing: skip to the next one due.
            // And when frames take longer than a period, the next one due cannot be on time
            // either: aim at the first tick a frame started now can still meet, given how long
            // frames take now (so a slow scene shows fewer fresh frames, each at its own tick,
            // instead of none).
            std::int64_t due = outputTick_.load(std::memory_order_acquire);
            const std::int64_t expected_ns = expectedFrame_ns_.load(std::memory_order_relaxed);
            if (expected_ns > 0) {
                due = std::max(due, wall_.tickAt(monotonicNow_ns() + expected_ns) + 1);
            }
            if (r < due) {
                renderSkipped_ += due - r;
                live_.skipped.fetch_add(due - r, std::memory_order_relaxed);
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
        if (wall) {
            // Just in time: a frame started long before its deadline would show a pose
            // extrapolated that much further ahead and older telemetry. Start it when the
            // slowest recent frames would still make it with a period to spare (the slots
            // bound how far ahead it can be anyway), in slices so that a stop is seen.
            const std::int64_t lead_ns = leadFrame_ns_.load(std::memory_order_relaxed);
            if (lead_ns > 0) {
                const std::int64_t startAt = wall_.deadline_ns(r) - lead_ns;
                for (std::int64_t now = monotonicNow_ns(); now < startAt; now = monotonicNow_ns()) {
                    if (stop_.load(std::memory_order_acquire)) goto done;
                    WallClock::sleepUntil(std::min(startAt, now + 20'000'000));
                }
            }
        }
        {
            // Trigger clock: the slot is in hand, so the frame starts as soon as its edge comes.
            std::int64_t edge_ns = 0;
            if (trig && !waitTrigger(edge_ns)) goto done;
            const std::int64_t t0_ns = monotonicNow_ns();
            // t_k: the time of the frame's (last) exposure. Trigger: the edge starts the
            // (first) exposure, so t_sample_s = t_edge + e/2, and field 1 one field later.
            const double t_k = trig ? wall_.runTime_s(edge_ns) + 0.5 * exposure_s_ +
                                          static_cast<double>(fields_ - 1) * field_s_
                                    : tickTime_s(r);
            // "Now" for telemetry: the wall clock's reading, or under the sim clock the
            // instant this frame's render nominally starts, one period before its deadline.
            const double now_s =
                wall || trig ? wall_.runTime_s(t0_ns) : (r > 0 ? sim_.tickTime_s(r - 1) : 0.0);
            Slot& sl = slots_[slot];
            sl.start_ns = t0_ns;
            sl.edge_ns = edge_ns;
            renderFrame(sl, r, t_k, now_s);
        }
        rendered_.push(slot);
        renderedSeq_.fetch_add(1, std::memory_order_release);
        renderedSeq_.notify_all();
        ++r;
    }
done:
    renderFinished_.store(true, std::memory_order_release);
    renderedSeq_.fetch_add(1, std::memory_order_release);
    renderedSeq_.notify_all();
}

// ---- camera thread ---------------------------------------------------------------------------

void FrameLoop::cameraThread(bool realtime) {
    std::string msg;
    applyThreadSpec(kThreadCamera, realtime, msg);
    cameraMessage_ = msg.empty() ? "ok" : msg;
    postMessage();
    for (;;) {
        int slot = -1;
        bool got = false;
        for (;;) {
            const std::uint32_t seq = renderedSeq_.load(std::memory_order_acquire);
            if (rendered_.pop(slot)) {
                got = true;
                break;
            }
            // Frames rendered before the render thread stopped are still exposed.
            if (renderFinished_.load(std::memory_order_acquire) && !rendered_.peek(slot)) break;
            if (stop_.load(std::memory_order_acquire)) break;
            renderedSeq_.wait(seq, std::memory_order_acquire);
        }
        if (!got) break;
        Slot& sl = slots_[slot];
        exposeFrame(sl);
        const std::int64_t took_ns = monotonicNow_ns() - sl.start_ns;
        frameTime_.add(static_cast<double>(took_ns) * 1e-9);
        noteFrameLatency(took_ns);
        ++framesRendered_;
        ready_.push(slot);
        readySeq_.fetch_add(1, std::memory_order_release);
        readySeq_.notify_all();
    }
    framesDone_.store(true, std::memory_order_release);
    readySeq_.fetch_add(1, std::memory_order_release);
    readySeq_.notify_all();
}

// ---- output thread ---------------------------------------------------------------------------

bool FrameLoop::waitReady(std::int64_t k) noexcept {
    for (;;) {
        const std::uint32_t seq = readySeq_.load(std::memory_order_acquire);
        int slot = -1;
        if (ready_.peek(slot) && slots_[slot].frame >= k) return true;
        if (framesDone_.load(std::memory_order_acquire)) {
            return ready_.peek(slot);  // frames handed over before the end
        }
        if (stop_.load(std::memory_order_acquire)) return false;
        readySeq_.wait(seq, std::memory_order_acquire);
    }
}

void FrameLoop::emit(int slot, std::int64_t tick, bool repeat, std::int64_t now_ns) {
    const Slot& s = slots_[slot];
    const bool wall = config_.clock != ClockKind::Sim;  // emission times are real
    OutputFrame of;
    of.meta = &s.meta;
    of.radiance = RadianceFrame{s.lpe_pe_s_m2_sr.cview(), s.band_W_m2_sr.cview()};
    of.counts = s.counts.cview();
    of.bits = camera_.bits();
    of.tick = tick;
    of.repeat = repeat;
    of.emit_s = wall ? wall_.runTime_s(now_ns) : sim_.tickTime_s(tick);
    of.emitMonotonic_ns = wall ? now_ns : 0;
    const std::int64_t s0 = monotonicNow_ns();
    // Hand the frame to every output's queue. Under the sim clock every frame must reach every
    // output: wait for room. Otherwise a full queue loses this frame for that output alone.
    const bool waitForRoom = config_.clock == ClockKind::Sim;
    for (auto& ch : channels_) {
        if (waitForRoom) {
            ch->offerWait(of, stop_);
        } else {
            ch->offer(of);
        }
    }
    const std::int64_t s1 = monotonicNow_ns();
    stats_.sinkTime.add(static_cast<double>(s1 - s0) * 1e-9);
    checkChannels();
    // Render start → emitted: the pipeline's own latency, with or without telemetry.
    if (!repeat) stats_.renderLatency.add(static_cast<double>(s1 - s.start_ns) * 1e-9);
    if (wall) {
        if (lastEmit_ns_ != 0) stats_.period.add(static_cast<double>(now_ns - lastEmit_ns_) * 1e-9);
        lastEmit_ns_ = now_ns;
    }
    if (s.meta.triggerEdge_ns != 0 && !repeat) {
        trigger_.latency.add(static_cast<double>(s1 - s.meta.triggerEdge_ns) * 1e-9);
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
    postMessage();
    const bool wall = config_.clock == ClockKind::Wall;
    const bool trig = config_.clock == ClockKind::Trigger;
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
                stats_.counters.ticks += kNow - k;  // they passed: ticks counts them too
                stats_.counters.skippedTicks += kNow - k;
                stats_.counters.deadlineMisses += kNow - k;
                live_.misses.fetch_add(kNow - k, std::memory_order_relaxed);
                k = kNow;
                if (config_.frames >= 0 && k >= config_.frames) break;
            }
            stats_.wakeLate.add(static_cast<double>(now_ns - wall_.deadline_ns(k)) * 1e-9);
        } else if (!waitReady(k)) {
            break;
        } else if (trig) {
            now_ns = monotonicNow_ns();  // emitted as soon as it is ready
        }
        const std::int64_t w0 = monotonicNow_ns();
        ++stats_.counters.ticks;
        // Take frame k from the ready ring; frames older than k missed their tick.
        int use = -1;
        int slot = -1;
        while (ready_.peek(slot)) {
            if (slots_[slot].frame < k) {
                // Rendered, but after its tick: never shown (its tick was a miss).
                ready_.pop(slot);
                free_.push(slot);
                ++stats_.counters.lateFrames;
                live_.late.fetch_add(1, std::memory_order_relaxed);
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
            emit(held, k, false, now_ns);
            ++stats_.counters.framesEmitted;
            live_.emitted.fetch_add(1, std::memory_order_relaxed);
        } else if (!wall && framesDone_.load(std::memory_order_acquire)) {
            break;  // the render and camera threads stopped early (stop requested)
        } else {
            ++stats_.counters.deadlineMisses;
            live_.misses.fetch_add(1, std::memory_order_relaxed);
            freeSeq_.fetch_add(1, std::memory_order_release);
            freeSeq_.notify_all();
            if (config_.latePolicy == LatePolicy::Repeat && held >= 0) {
                emit(held, k, true, now_ns);
                ++stats_.counters.repeats;
                live_.repeats.fetch_add(1, std::memory_order_relaxed);
            } else {
                // Nothing sent on this tick (drop policy, or no frame to repeat yet).
                ++stats_.counters.droppedFrames;
                live_.dropped.fetch_add(1, std::memory_order_relaxed);
                checkChannels();
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
