#include "rt/loop/frame_loop.h"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "rt/clock/threads.h"
#include "sim/core/rng.h"

namespace nvs::rt {

ExposureTiming exposureTiming(FrameRate rate, ScanKind scan, double exposure_s) noexcept {
    ExposureTiming t;
    t.fields = scan == ScanKind::Interlaced ? 2 : 1;
    t.field_s = rate.period_s() / (scan == ScanKind::Interlaced ? 2.0 : 1.0);
    t.exposure_s = exposure_s > 0.0 ? exposure_s : t.field_s;
    t.firstLead_s = static_cast<double>(t.fields - 1) * t.field_s + 0.5 * t.exposure_s;
    return t;
}

FrameLoop::FrameLoop(const LoopConfig& config, PlatformSource& platform, RenderStage& render,
                     CameraStage& camera, std::vector<FrameSink*> sinks)
    : config_(config),
      platform_(platform),
      render_(render),
      camera_(camera),
      sinks_(std::move(sinks)),
      wall_(config.rate),
      sim_(config.rate),
      period_ns_(WallClock(config.rate).deadline_ns(1)) {
    const ExposureTiming timing = exposureTiming(config.rate, config.scan, config.exposure_s);
    fields_ = timing.fields;
    field_s_ = timing.field_s;
    exposure_s_ = timing.exposure_s;
    firstExposureLead_ns_ = std::llround(timing.firstLead_s * 1e9);
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
    PacingContext ctx{wall_, sim_,          stop_,      *this,       events_, stats_,  trigger_,
                      live_, config.frames, period_ns_, exposure_s_, fields_, field_s_};
    // With a gate line, frame k's first exposure is its deadline: its pulse rises there, so the
    // frame must be made before.
    if (!observers_.empty()) ctx.markLead_ns = firstExposureLead_ns_;
    pacing_ = makePacing(config.clock, ctx, config.trigger, config.triggerTimeout_s);
}

FrameLoop::~FrameLoop() {
    requestStop();
    join();
}

double FrameLoop::tickTime_s(std::int64_t k) const {
    return pacing_->tickTime_s(k);
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
    prepare(messages);
    go(0);
}

void FrameLoop::prepare(std::vector<std::string>& messages) {
    prepared_ns_ = monotonicNow_ns();
    startWorkers();
    for (auto& ch : channels_)
        ch->start(config_.realtime);
    if (config_.realtime) {
        std::string msg;
        if (lockMemory(msg) != 0) messages.push_back(msg);
    }
    // The loop's threads are made before the run clock's origin is taken, and wait for it
    // (awaitGo): making a thread is slow once memory is locked (MCL_FUTURE faults in and locks
    // its whole stack, 8 MiB by default: 7 ms on the host, about 0.5 s in the HIL test's
    // emulated VM); made after the origin, they ate frame 0's period and the next ones'.
    const bool rt = config_.realtime;
    renderThread_ = std::thread([this, rt] { renderThread(rt); });
    cameraThread_ = std::thread([this, rt] { cameraThread(rt); });
    outputThread_ = std::thread([this, rt] { outputThread(rt); });
    // Collect what each thread said about its real-time settings. Each thread writes its
    // message first thing and never again, then posts it (release); waiting here for all
    // three posts (acquire) makes the strings safe to read.
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

void FrameLoop::go(std::int64_t origin_ns) {
    // Every thread runs and waits. Frame 0's first exposure (t_0 − exposure/2, and a field
    // earlier when interlaced: the gate pulse rises there) is one period away, so frame 0 has
    // a whole period to be made before it. The origin is published to the threads by go_
    // (release; they acquire it).
    const std::int64_t now_ns = monotonicNow_ns();
    stats_.loopStart_s = static_cast<double>(now_ns - prepared_ns_) * 1e-9;
    if (origin_ns == 0) origin_ns = now_ns + originLead_ns();
    wall_.start(origin_ns + std::llround(config_.skew_s * 1e9));
    pacing_->started(now_ns);
    go_.store(true, std::memory_order_release);
    go_.notify_all();
}

void FrameLoop::awaitGo() noexcept {
    go_.wait(false, std::memory_order_acquire);
}

void FrameLoop::postMessage() noexcept {
    messagesPosted_.fetch_add(1, std::memory_order_release);
    messagesPosted_.notify_all();
}

void FrameLoop::requestStop() noexcept {
    interrupted_.store(true, std::memory_order_release);
    stop_.store(true, std::memory_order_release);
    go_.store(true, std::memory_order_release);  // threads still waiting for the origin
    go_.notify_all();
    for (auto& ch : channels_)
        ch->wake();  // an output thread waiting for room (sim clock) sees the stop
    notify(readySeq_);
    notify(freeSeq_);
    notify(renderedSeq_);
}

void FrameLoop::notify(std::atomic<std::uint32_t>& seq) noexcept {
    seq.fetch_add(1, std::memory_order_release);
    seq.notify_all();
}

void FrameLoop::join() {
    if (renderThread_.joinable()) renderThread_.join();
    if (cameraThread_.joinable()) cameraThread_.join();
    if (outputThread_.joinable()) outputThread_.join();
    drainChannels();
    joinWorkers();
    // The outputs' counters are their channels'; the loop's own went through events_.
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

void FrameLoop::renderFrame(Slot& s, std::int64_t r, const FrameStart& at) noexcept {
    s.start_ns = at.start_ns;
    s.edge_ns = at.edge_ns;
    for (int f = 0; f < fields_; ++f) {
        // Field f of an interlaced frame: t_f = t_k − (1 − f)·T_f; progressive: t_k.
        // A rig channel's skew: the exposure that much late on the rig's time line.
        const double t_f =
            at.t_k_s - static_cast<double>(fields_ - 1 - f) * field_s_ + config_.skew_s;
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
        platform_.sample(t_f, at.now_s, req.platform);
        m.truthCount = 0;
        render_.render(req, out, m);
    }
    s.frame = r;
    lastRendered_ = r;
}

bool FrameLoop::takeFreeSlot(int& slot) noexcept {
    while (!free_.pop(slot)) {
        const std::uint32_t seq = freeSeq_.load(std::memory_order_acquire);
        if (free_.peek(slot)) continue;
        if (stop_.load(std::memory_order_acquire)) return false;
        freeSeq_.wait(seq, std::memory_order_acquire);
    }
    return true;
}

void FrameLoop::renderThread(bool realtime) {
    std::string msg;
    applyThreadSpec(kThreadRender, realtime, msg);
    renderMessage_ = msg.empty() ? "ok" : msg;
    postMessage();
    awaitGo();
    const auto pastEnd = [this](std::int64_t r) {
        return config_.frames >= 0 && r >= config_.frames;
    };
    for (std::int64_t r = 0; !stop_.load(std::memory_order_acquire) && !pastEnd(r); ++r) {
        r = pacing_->frameDue(r);  // wall clock: frames whose tick has passed are skipped
        if (pastEnd(r)) break;
        int slot = -1;
        if (!takeFreeSlot(slot)) break;
        FrameStart at;
        if (!pacing_->startFrame(r, at)) break;  // wall: just in time; trigger: at its edge
        renderFrame(slots_[slot], r, at);
        rendered_.push(slot);
        notify(renderedSeq_);
    }
    renderFinished_.store(true, std::memory_order_release);
    notify(renderedSeq_);
}

// ---- camera thread ---------------------------------------------------------------------------

void FrameLoop::scheduleExposure(const Slot& s, int field, double gate_s) noexcept {
    // The exposure on the loop's timeline, for the gate pulse: it is scheduled now, while the
    // frame is made ahead of its emission.
    ExposureWindow w;
    w.frame = s.frame;
    w.field = field;
    w.t_sample_s = s.request[field].t_sample_s;
    w.start_s = w.t_sample_s - 0.5 * exposure_s_;
    w.exposure_s = exposure_s_;
    w.gate_s = gate_s;
    // The loop's own clock runs skew_s behind the rig's (its origin moved by the skew).
    w.startMonotonic_ns = pacing_->monotonic_ns(w.start_s - config_.skew_s);
    for (ExposureObserver* o : observers_)
        o->exposureScheduled(w);
}

namespace {
// A set of truth boxes, `count` of them, into `to` (kMaxTruthBoxes long); its count into
// `toCount`.
void copyTruth(const TruthBox* from, std::int32_t count, TruthBox* to,
               std::int32_t& toCount) noexcept {
    toCount = std::min(count, kMaxTruthBoxes);
    std::copy(from, from + toCount, to);
}
}  // namespace

void FrameLoop::weaveFields(Slot& s) noexcept {
    // Weave: field 1's rows (odd, top field first). The frame is described by field 1, which
    // completes it (messages.h); field[0] keeps the first field's own exposure.
    const std::size_t radBytes = static_cast<std::size_t>(config_.width) * sizeof(float);
    const std::size_t cntBytes = static_cast<std::size_t>(config_.width) * sizeof(std::uint16_t);
    const bool lpe = !s.lpe_pe_s_m2_sr.empty();
    const bool band = !s.band_W_m2_sr.empty();
    for (int y = config_.topFieldFirst ? 1 : 0; y < config_.height; y += 2) {
        if (lpe) std::memcpy(s.lpe_pe_s_m2_sr.row(y), s.fieldLpe_pe_s_m2_sr.row(y), radBytes);
        if (band) std::memcpy(s.band_W_m2_sr.row(y), s.fieldBand_W_m2_sr.row(y), radBytes);
        std::memcpy(s.counts.view().row(y), fieldCounts_.cview().row(y), cntBytes);
    }
    s.meta.t_sample_s = s.fieldMeta.t_sample_s;
    s.meta.platform = s.fieldMeta.platform;
    s.meta.camera = s.fieldMeta.camera;
    s.meta.rig = s.fieldMeta.rig;
    copyTruth(s.fieldMeta.truth, s.fieldMeta.truthCount, s.meta.truth, s.meta.truthCount);
}

void FrameLoop::exposeFrame(Slot& s) noexcept {
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
        applied.t_sample_s = t_f;
        applied.gain_V = req.platform.gain_V;
        applied.gate_s = req.platform.gate_s;
        camera_.expose(req, in, counts, applied);
        applied.t_sample_s = t_f;
        applied.camera = m.camera;  // this field's camera and own truth (at t_f)
        copyTruth(m.truth, m.truthCount, applied.truth, applied.truthCount);
        m.frame = s.frame;
        m.t_sample_s = t_f;
        m.exposure_s = exposure_s_;
        m.platform = req.platform;  // as commanded
        stale = stale || req.platform.stale;
    }
    if (fields_ == 2) weaveFields(s);
    // A frame made after its deadline (wall clock: its tick, or with a gate line its first
    // exposure's start) is late: the output thread drops it, and its exposures get no gate
    // pulse, so that every pulse on the line is an emitted frame's and rises at its window's
    // start. The exposures are scheduled here, once the frame is made (their windows lie ahead).
    s.late = pacing_->pastTick(s.frame, monotonicNow_ns());
    if (!s.late) {
        for (int f = 0; f < fields_ && !observers_.empty(); ++f)
            scheduleExposure(s, f, s.meta.field[f].gate_s);
    }
    s.meta.fieldCount = fields_;
    s.meta.triggerEdge_ns = s.edge_ns;
    s.meta.rig.stampJitter_s = faultJitter_s(s.frame);
    if (stale) events_.count(LoopEvent::StaleFrame);
    live_.stale.store(stale, std::memory_order_relaxed);
}

bool FrameLoop::takeRendered(int& slot) noexcept {
    for (;;) {
        const std::uint32_t seq = renderedSeq_.load(std::memory_order_acquire);
        if (rendered_.pop(slot)) return true;
        // Frames rendered before the render thread stopped are still exposed.
        if (renderFinished_.load(std::memory_order_acquire) && !rendered_.peek(slot)) return false;
        if (stop_.load(std::memory_order_acquire)) return false;
        renderedSeq_.wait(seq, std::memory_order_acquire);
    }
}

void FrameLoop::cameraThread(bool realtime) {
    std::string msg;
    applyThreadSpec(kThreadCamera, realtime, msg);
    cameraMessage_ = msg.empty() ? "ok" : msg;
    postMessage();
    awaitGo();
    for (int slot = -1; takeRendered(slot);) {
        Slot& sl = slots_[slot];
        exposeFrame(sl);
        const std::int64_t made_ns = monotonicNow_ns();
        const std::int64_t took_ns = made_ns - sl.start_ns;
        if (stats_.firstFrame < 0) {
            stats_.firstFrame = sl.frame;
            stats_.firstFrameMade_s = wall_.runTime_s(made_ns);
        }
        stats_.frameTime.add(static_cast<double>(took_ns) * 1e-9);
        pacing_->frameMade(took_ns);  // wall clock: what the render thread aims at
        events_.count(LoopEvent::FrameRendered);
        ready_.push(slot);
        notify(readySeq_);
    }
    framesDone_.store(true, std::memory_order_release);
    notify(readySeq_);
}

// ---- output thread ---------------------------------------------------------------------------

namespace {
// Frame k's fault draws: word 0 decides a drop, word 1 the stamp jitter.
void faultWords(std::uint64_t seed, std::int64_t k, std::uint32_t w[4]) noexcept {
    PixelRng(seed, RngStream::Faults, static_cast<std::uint64_t>(k)).block(0, 0, 0, w);
}
}  // namespace

bool FrameLoop::faultDrop(std::int64_t k) const noexcept {
    if (!(config_.dropProbability > 0.0)) return false;
    std::uint32_t w[4];
    faultWords(config_.faultSeed, k, w);
    return uniformFromWord(w[0]) < config_.dropProbability;
}

double FrameLoop::faultJitter_s(std::int64_t k) const noexcept {
    if (!(config_.stampJitter_s > 0.0)) return 0.0;
    std::uint32_t w[4];
    faultWords(config_.faultSeed, k, w);
    return config_.stampJitter_s * static_cast<double>(normalFromWord(w[1]));
}

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
    OutputFrame of;
    of.meta = &s.meta;
    of.radiance = RadianceFrame{s.lpe_pe_s_m2_sr.cview(), s.band_W_m2_sr.cview()};
    of.counts = s.counts.cview();
    of.bits = camera_.bits();
    of.tick = tick;
    of.repeat = repeat;
    pacing_->stamp(of, now_ns);  // emit_s, emitMonotonic_ns; the period
    const std::int64_t s0 = monotonicNow_ns();
    // Hand the frame to every output's queue. Where every frame must reach every output (sim
    // clock), wait for room. Otherwise a full queue loses this frame for that output alone.
    const bool waitForRoom = pacing_->lossless();
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
    if (s.meta.triggerEdge_ns != 0 && !repeat) {
        trigger_.latency.add(static_cast<double>(s1 - s.meta.triggerEdge_ns) * 1e-9);
    }
    const double rx_s = s.meta.platform.telemetryRx_s;
    if (rx_s >= 0.0) {
        // Telemetry receive → frame emitted (written to every sink).
        const double out_s = pacing_->writtenTime_s(s1, of.emit_s);
        stats_.latency.add(out_s - rx_s);
        live_.lastLatency_ns.store(static_cast<std::int64_t>((out_s - rx_s) * 1e9),
                                   std::memory_order_relaxed);
    }
}

int FrameLoop::takeReady(std::int64_t k) noexcept {
    // Take frame k from the ready ring; frames older than k missed their tick.
    int slot = -1;
    while (ready_.peek(slot)) {
        if (slots_[slot].frame < k || slots_[slot].late) {
            // Rendered, but after its tick: never shown (its tick was a miss), nor marked on
            // the gate line (exposeFrame).
            ready_.pop(slot);
            free_.push(slot);
            events_.count(LoopEvent::LateFrame);
            continue;
        }
        if (slots_[slot].frame != k) break;
        ready_.pop(slot);
        return slot;
    }
    return -1;
}

void FrameLoop::missTick(std::int64_t k, std::int64_t now_ns, int held) {
    notify(freeSeq_);
    if (config_.latePolicy == LatePolicy::Repeat && held >= 0) {
        emit(held, k, true, now_ns);
        events_.count(LoopEvent::MissRepeated);
    } else {
        // Nothing sent on this tick (drop policy, or no frame to repeat yet).
        events_.count(LoopEvent::MissDropped);
        checkChannels();
    }
}

bool FrameLoop::outputTick(std::int64_t k, std::int64_t now_ns, int& held) {
    const std::int64_t w0 = monotonicNow_ns();
    events_.count(LoopEvent::Tick);
    int use = takeReady(k);
    const std::int64_t overhead_ns = monotonicNow_ns() - w0;
    if (use >= 0 && faultDrop(k)) {
        // A rig's drop fault: made, never sent; the next frame sent says how many were lost.
        free_.push(use);
        notify(freeSeq_);
        use = -1;
        ++faultDropped_;
        ++faultDrops_;
        return true;
    }
    if (use >= 0) {
        slots_[use].meta.rig.droppedBefore = faultDropped_;
        faultDropped_ = 0;
        if (held >= 0) free_.push(held);
        held = use;
        notify(freeSeq_);
        emit(held, k, false, now_ns);
        events_.count(LoopEvent::FrameEmitted);
    } else if (!pacing_->onDeadlines() && framesDone_.load(std::memory_order_acquire)) {
        return false;  // the render and camera threads stopped early (stop requested)
    } else {
        missTick(k, now_ns, held);
    }
    // The loop's own work on this tick; the sinks' time is measured apart (sinkTime).
    stats_.overhead.add(static_cast<double>(overhead_ns) * 1e-9);
    return true;
}

void FrameLoop::outputThread(bool realtime) {
    std::string msg;
    applyThreadSpec(kThreadOutput, realtime, msg);
    outputMessage_ = msg.empty() ? "ok" : msg;
    postMessage();
    awaitGo();
    int held = -1;  // the slot emitted last, kept to repeat
    const std::int64_t t_start = monotonicNow_ns();
    for (std::int64_t k = 0; config_.frames < 0 || k < config_.frames; ++k) {
        if (stop_.load(std::memory_order_acquire)) break;
        // Wall clock: sleep to deadline k (lost ticks skipped); otherwise wait for frame k.
        std::int64_t now_ns = 0;
        if (!pacing_->awaitTick(k, now_ns)) break;
        if (!outputTick(k, now_ns, held)) break;
        pacing_->tickDone(k + 1);
    }
    stats_.elapsed_s = static_cast<double>(monotonicNow_ns() - t_start) * 1e-9;
    // Let the render thread go: nothing more will be taken.
    stop_.store(true, std::memory_order_release);
    notify(freeSeq_);
    outputDone_.store(true, std::memory_order_release);
}

}  // namespace nvs::rt
