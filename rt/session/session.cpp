#include "rt/session/session.h"

#include <cmath>
#include <cstring>

#include "drivers/sinks/sinks.h"
#include "sim/core/error.h"

namespace nvs::rt {

// The caller's output: a ring of preallocated frames. write() (the output's own thread, rt/loop
// sink_channel.h) waits for a free slot; the caller's next() waits for a full one.
class Session::Ring final : public msg::FrameSink {
  public:
    // The slots are sized once the run has read its scenario (Session's constructor), before
    // the run starts.
    void size(int width, int height, int depth) {
        slots_.resize(static_cast<std::size_t>(depth));
        for (PulledFrame& f : slots_) {
            f.counts.assign(static_cast<std::size_t>(width) * static_cast<std::size_t>(height), 0);
            f.width = width;
            f.height = height;
            f.metaJson.reserve(kMetaBytes);
        }
    }
    const char* name() const noexcept override { return "pull"; }
    msg::SinkInputs inputs() const noexcept override { return {true, false, false}; }

    int write(const msg::OutputFrame& frame) noexcept override {
        std::unique_lock<std::mutex> lock(mutex_);
        space_.wait(lock, [&] { return count_ < slots_.size() || cancelled_; });
        // Abandoned by stop(): the frame is dropped as asked, not a failed write.
        if (cancelled_) return 0;
        PulledFrame& f = slots_[(head_ + count_) % slots_.size()];
        lock.unlock();
        // The slot is the writer's alone until it is counted in.
        const int w = frame.counts.width(), h = frame.counts.height();
        if (w != f.width || h != f.height) return -EINVAL;
        for (int y = 0; y < h; ++y) {
            std::memcpy(f.counts.data() + static_cast<std::size_t>(y) * static_cast<std::size_t>(w),
                        frame.counts.row(y), static_cast<std::size_t>(w) * sizeof(std::uint16_t));
        }
        f.bits = frame.bits;
        f.tick = frame.tick;
        f.repeat = frame.repeat;
        f.emit_s = frame.emit_s;
        f.emitMonotonic_ns = frame.emitMonotonic_ns;
        if (frame.meta != nullptr) {
            f.index = frame.meta->frame;
            f.t_sample_s = frame.meta->t_sample_s;
            f.exposure_s = frame.meta->exposure_s;
        }
        // The meta output's record, formatted into the slot's reserved string (no allocation).
        f.metaJson.resize(kMetaBytes);
        const std::size_t n = drivers::MetaJsonlSink::format(frame, f.metaJson.data(), kMetaBytes);
        // One record without its line end.
        f.metaJson.resize(n > 0 && f.metaJson[n - 1] == '\n' ? n - 1 : n);
        lock.lock();
        ++count_;
        ++written_;
        ready_.notify_one();
        return 0;
    }
    // The loop cancels a write that makes no progress for a second at the end of a run (a
    // vanished pipe reader). The caller here is still there and drains the ring in finish(), so
    // however long it spends on a frame, it gets every one: only Session::stop() abandons.
    void cancel() noexcept override {}
    void abandon() noexcept {
        std::lock_guard<std::mutex> lock(mutex_);
        cancelled_ = true;
        space_.notify_all();
    }
    int close() noexcept override {
        end();
        return 0;
    }
    std::string status() const override {
        std::lock_guard<std::mutex> lock(mutex_);
        return "pull: " + std::to_string(written_) + " frames";
    }

    // The caller: swaps the oldest frame into `out`; false once ended and empty.
    bool take(PulledFrame& out) {
        std::unique_lock<std::mutex> lock(mutex_);
        ready_.wait(lock, [&] { return count_ > 0 || ended_; });
        if (count_ == 0) return false;
        PulledFrame& f = slots_[head_];
        // The caller's buffers become the slot's, so that a caller who keeps the last frame
        // and passes a fresh one costs the ring one allocation, and a reused one costs none.
        std::swap(out, f);
        if (f.counts.size() != out.counts.size()) f.counts.assign(out.counts.size(), 0);
        f.width = out.width;
        f.height = out.height;
        if (f.metaJson.capacity() < kMetaBytes) f.metaJson.reserve(kMetaBytes);
        head_ = (head_ + 1) % slots_.size();
        --count_;
        space_.notify_one();
        return true;
    }
    // The run is over: take() drains what is left and then returns false.
    void end() {
        std::lock_guard<std::mutex> lock(mutex_);
        ended_ = true;
        ready_.notify_all();
    }

  private:
    static constexpr std::size_t kMetaBytes = 16384;
    mutable std::mutex mutex_;
    std::condition_variable space_, ready_;
    std::vector<PulledFrame> slots_;
    std::size_t head_ = 0, count_ = 0;
    std::int64_t written_ = 0;
    bool cancelled_ = false, ended_ = false;
};

Session::Session(const SessionOptions& opts) {
    if (opts.depth < 1 || opts.depth > SinkChannel::kMaxDepth) {
        throw SetupError("depth must be in [1, " + std::to_string(SinkChannel::kMaxDepth) + "]");
    }
    ring_ = std::make_unique<Ring>();
    RunRequest req;
    req.scenario = opts.scenario;
    req.outputs = opts.outputs;
    req.clock = opts.clock;
    req.frames = opts.frames;
    req.telemetry = opts.telemetry;
    req.dirs = opts.dirs;
    req.overrides = opts.overrides;
    req.callerSinks.push_back({opts.channel, ring_.get()});
    req.stop = &stop_;
    // The run's setup checks the channel (a rig's name, none for one camera).
    run_ = std::make_unique<ScenarioRun>(req, opts.statusLines ? stderr : nullptr);
    // The format of the channel the caller pulls, from the scenario as the run read it.
    const Scenario& whole = run_->scenario();
    std::size_t index = 0;
    while (index < whole.channels.size() && whole.channels[index].name != opts.channel)
        ++index;
    const Scenario sc = channelScenario(whole, index);
    width_ = sc.width;
    height_ = sc.height;
    bits_ = sc.bits;
    rate_hz_ = sc.rate.hz();
    fieldOrder_ = sc.fieldOrder();
    const drivers::PixelAspect aspect = pixelAspectOf(sc);
    aspectNum_ = aspect.num;
    aspectDen_ = aspect.den;
    name_ = sc.name;
    if (opts.frames) {
        frames_ = *opts.frames;
    } else if (sc.duration_s) {
        frames_ = static_cast<std::int64_t>(std::ceil(*sc.duration_s * rate_hz_ - 1e-9));
    }
    ring_->size(width_, height_, opts.depth);
    thread_ = std::thread([this] {
        int rc = kRunFailed;
        try {
            rc = run_->execute();
        } catch (const std::exception& e) {
            std::fprintf(stderr, "nvstim: %s\n", e.what());
        }
        exitStatus_.store(rc);
        ring_->end();
    });
}

Session::~Session() {
    finish(true);
}

bool Session::next(PulledFrame& out) {
    return ring_->take(out);
}

void Session::stop() {
    stop_.store(true);
    ring_->abandon();
}

int Session::finish(bool stopFirst) {
    if (joined_) return exitStatus_.load();
    if (stopFirst) stop();
    // A run that was not stopped ends by itself; its frames must be taken for it to do so
    // under the sim clock, so whatever is left is dropped here.
    PulledFrame drain;
    while (!stopFirst && ring_->take(drain)) {
    }
    if (thread_.joinable()) thread_.join();
    joined_ = true;
    return exitStatus_.load();
}

}  // namespace nvs::rt
