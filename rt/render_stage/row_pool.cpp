#include "rt/render_stage/row_pool.h"

#include <algorithm>
#include <string>

#include "rt/clock/threads.h"

namespace nvs::rt {

namespace {
// How long a thread spins before it sleeps: about 50 µs of pause instructions.
constexpr int kSpinPauses = 2000;
inline void cpuPause() {
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#endif
}
}  // namespace

RowPool::RowPool(int threads, bool realtime, ThreadId worker) : n_(threads < 1 ? 1 : threads) {
    for (int i = 1; i < n_; ++i) {
        workers_.emplace_back([this, realtime, worker] {
            std::string refused;  // already reported by the calling thread's own spec
            applyThreadSpec(worker, realtime, refused);
            loop();
        });
    }
}

RowPool::~RowPool() {
    {
        std::lock_guard<std::mutex> g(m_);
        stop_ = true;
        ++job_.generation;
        published_.store(job_.generation, std::memory_order_release);
    }
    wake_.notify_all();
    for (auto& t : workers_)
        t.join();
}

void RowPool::run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept {
    if (n_ == 1 || rows <= 1) {
        if (rows > 0) fn(ctx, 0, rows);
        return;
    }
    Job job;
    bool sleeping = false;
    {
        std::lock_guard<std::mutex> g(m_);
        job.generation = job_.generation + 1;
        job.rows = rows;
        // Eight chunks a thread: small enough to even out a thread held up for a while, large
        // enough that taking one costs nothing against its rows.
        job.chunk = std::max(1, rows / (8 * n_));
        job.chunks = (rows + job.chunk - 1) / job.chunk;
        job.fn = fn;
        job.ctx = ctx;
        finished_.store(0, std::memory_order_relaxed);
        next_.store(static_cast<std::uint64_t>(job.generation) << 32, std::memory_order_release);
        job_ = job;
        published_.store(job.generation, std::memory_order_release);
        sleeping = sleepers_ > 0;
    }
    if (sleeping) wake_.notify_all();
    work(job);
    // Wait for the chunks other threads took (not for threads that took none).
    for (int i = 0; i < kSpinPauses; ++i) {
        if (finished_.load(std::memory_order_acquire) == job.chunks) return;
        cpuPause();
    }
    std::unique_lock<std::mutex> l(m_);
    done_.wait(l, [&] { return finished_.load(std::memory_order_acquire) == job.chunks; });
}

void RowPool::work(const Job& job) noexcept {
    const std::uint64_t mine = static_cast<std::uint64_t>(job.generation) << 32;
    std::uint64_t cur = next_.load(std::memory_order_acquire);
    for (;;) {
        // Take chunk c of this run, if this run still has one.
        if ((cur & ~std::uint64_t{0xFFFFFFFFu}) != mine) return;
        const int c = static_cast<int>(cur & 0xFFFFFFFFu);
        if (c >= job.chunks) return;
        if (!next_.compare_exchange_weak(cur, cur + 1, std::memory_order_acq_rel,
                                         std::memory_order_acquire)) {
            continue;
        }
        const int y0 = c * job.chunk;
        job.fn(job.ctx, y0, std::min(job.rows, y0 + job.chunk));
        if (finished_.fetch_add(1, std::memory_order_acq_rel) + 1 == job.chunks) {
            // The last chunk: wake the caller if it waits (under m_, so that it cannot miss it).
            std::lock_guard<std::mutex> g(m_);
            done_.notify_one();
        }
        cur = next_.load(std::memory_order_acquire);
    }
}

void RowPool::loop() {
    std::uint32_t seen = 0;
    for (;;) {
        // The next run is often a few microseconds away: spin a while before sleeping.
        for (int i = 0; i < kSpinPauses; ++i) {
            if (published_.load(std::memory_order_acquire) != seen) break;
            cpuPause();
        }
        Job job;
        {
            std::unique_lock<std::mutex> l(m_);
            ++sleepers_;
            wake_.wait(l, [&] { return job_.generation != seen; });
            --sleepers_;
            if (stop_) return;
            job = job_;
            seen = job.generation;
        }
        work(job);
    }
}

}  // namespace nvs::rt
