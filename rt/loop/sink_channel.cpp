#include "rt/loop/sink_channel.h"

#include <algorithm>
#include <cstring>
#include <string>

#include "rt/clock/clock.h"
#include "rt/clock/threads.h"
#include "sim/core/error.h"

namespace nvs::rt {

SinkChannel::SinkChannel(FrameSink& sink, int depth, int width, int height,
                         RenderStage::Outputs images)
    : sink_(sink), direct_(sink.inputs().direct), depth_(std::clamp(depth, 1, kMaxDepth)) {
    const msg::SinkInputs in = sink.inputs();
    wantCounts_ = in.counts;
    wantRadiance_ = in.radiance;
    if (direct_) return;
    for (int i = 0; i < depth_; ++i) {
        auto e = std::make_unique<Entry>();
        if (wantCounts_) e->counts = ImageU16(width, height);
        if (wantRadiance_ && images.lpe_pe_s_m2_sr) e->lpe_pe_s_m2_sr = ImageF(width, height);
        if (wantRadiance_ && images.band_W_m2_sr) e->band_W_m2_sr = ImageF(width, height);
        entries_.push_back(std::move(e));
    }
}

SinkChannel::~SinkChannel() {
    finish();
    cancel();
    join();
}

void SinkChannel::start(bool realtime) {
    if (direct_ || thread_.joinable()) return;
    thread_ = std::thread([this, realtime] { run(realtime); });
}

namespace {

template <typename T>
void copyImage(ImageView<const T> from, Image<T>& to) noexcept {
    if (to.empty() || from.empty()) return;
    const int h = std::min(from.height(), to.height());
    const std::size_t bytes =
        static_cast<std::size_t>(std::min(from.width(), to.width())) * sizeof(T);
    for (int y = 0; y < h; ++y)
        std::memcpy(to.view().row(y), from.row(y), bytes);
}

}  // namespace

void SinkChannel::copyInto(Entry& e, const OutputFrame& f) noexcept {
    e.meta = *f.meta;
    e.frame = f;
    e.frame.meta = &e.meta;
    e.frame.counts = {};
    e.frame.radiance = {};
    if (wantCounts_ && !f.counts.empty()) {
        copyImage(f.counts, e.counts);
        e.frame.counts = e.counts.cview();
    }
    if (wantRadiance_) {
        if (!f.radiance.lpe_pe_s_m2_sr.empty() && !e.lpe_pe_s_m2_sr.empty()) {
            copyImage(f.radiance.lpe_pe_s_m2_sr, e.lpe_pe_s_m2_sr);
            e.frame.radiance.lpe_pe_s_m2_sr = e.lpe_pe_s_m2_sr.cview();
        }
        if (!f.radiance.band_W_m2_sr.empty() && !e.band_W_m2_sr.empty()) {
            copyImage(f.radiance.band_W_m2_sr, e.band_W_m2_sr);
            e.frame.radiance.band_W_m2_sr = e.band_W_m2_sr.cview();
        }
    }
}

void SinkChannel::writeDirect(const OutputFrame& f) noexcept {
    const std::int64_t t0 = monotonicNow_ns();
    if (sink_.write(f) < 0) {
        errors_.fetch_add(1, std::memory_order_relaxed);
    } else {
        written_.fetch_add(1, std::memory_order_relaxed);
    }
    writeLatency_.add(static_cast<double>(monotonicNow_ns() - t0) * 1e-9);
    if (sink_.failed()) failed_.store(true, std::memory_order_release);
}

bool SinkChannel::offer(const OutputFrame& f) noexcept {
    if (failed()) return false;
    offered_.fetch_add(1, std::memory_order_relaxed);
    if (direct_) {
        writeDirect(f);
        return true;
    }
    const std::uint64_t t = tail_.load(std::memory_order_relaxed);
    if (t - head_.load(std::memory_order_acquire) >= static_cast<std::uint64_t>(depth_)) {
        queueDrops_.fetch_add(1, std::memory_order_relaxed);
        return false;
    }
    Entry& e = *entries_[t % static_cast<std::uint64_t>(depth_)];
    copyInto(e, f);
    e.handoff_ns = monotonicNow_ns();
    tail_.store(t + 1, std::memory_order_release);
    queuedSeq_.fetch_add(1, std::memory_order_release);
    queuedSeq_.notify_one();
    return true;
}

bool SinkChannel::offerWait(const OutputFrame& f, const std::atomic<bool>& stop) noexcept {
    if (direct_) return offer(f);
    for (;;) {
        const std::uint32_t seq = freeSeq_.load(std::memory_order_acquire);
        if (failed() || stop.load(std::memory_order_acquire)) return false;
        const std::uint64_t t = tail_.load(std::memory_order_relaxed);
        if (t - head_.load(std::memory_order_acquire) < static_cast<std::uint64_t>(depth_)) {
            return offer(f);
        }
        freeSeq_.wait(seq, std::memory_order_acquire);
    }
}

void SinkChannel::wake() noexcept {
    freeSeq_.fetch_add(1, std::memory_order_release);
    freeSeq_.notify_all();
}

void SinkChannel::finish() noexcept {
    finishing_.store(true, std::memory_order_release);
    queuedSeq_.fetch_add(1, std::memory_order_release);
    queuedSeq_.notify_all();
}

void SinkChannel::cancel() noexcept {
    sink_.cancel();
}

void SinkChannel::join() {
    if (thread_.joinable()) thread_.join();
    done_.store(true, std::memory_order_release);
}

void SinkChannel::run(bool realtime) noexcept {
    std::string ignored;  // a refusal is the one the loop's threads report
    applyThreadSpec(kThreadSink, realtime, ignored);
    for (;;) {
        const std::uint32_t seq = queuedSeq_.load(std::memory_order_acquire);
        const std::uint64_t h = head_.load(std::memory_order_relaxed);
        if (h != tail_.load(std::memory_order_acquire)) {
            Entry& e = *entries_[h % static_cast<std::uint64_t>(depth_)];
            if (!failed()) {
                writingSince_ns_.store(monotonicNow_ns(), std::memory_order_release);
                const int rc = sink_.write(e.frame);
                const std::int64_t now = monotonicNow_ns();
                writingSince_ns_.store(0, std::memory_order_release);
                if (rc < 0) {
                    errors_.fetch_add(1, std::memory_order_relaxed);
                } else {
                    written_.fetch_add(1, std::memory_order_relaxed);
                    writeLatency_.add(static_cast<double>(now - e.handoff_ns) * 1e-9);
                }
                if (sink_.failed()) failed_.store(true, std::memory_order_release);
            }
            head_.store(h + 1, std::memory_order_release);
            wake();
            continue;
        }
        if (finishing_.load(std::memory_order_acquire)) break;
        queuedSeq_.wait(seq, std::memory_order_acquire);
    }
    done_.store(true, std::memory_order_release);
}

SinkChannelCounters SinkChannel::counters() const noexcept {
    SinkChannelCounters c;
    c.offered = offered_.load(std::memory_order_relaxed);
    c.written = written_.load(std::memory_order_relaxed);
    c.queueDrops = queueDrops_.load(std::memory_order_relaxed);
    c.errors = errors_.load(std::memory_order_relaxed);
    c.failed = failed();
    return c;
}

}  // namespace nvs::rt
