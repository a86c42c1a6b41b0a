#include "rt/render_stage/row_pool.h"

#include <algorithm>
#include <string>

#include "rt/clock/threads.h"

namespace nvs::rt {

RowPool::RowPool(int threads, bool realtime) : n_(threads < 1 ? 1 : threads) {
    for (int i = 1; i < n_; ++i) {
        workers_.emplace_back([this, realtime] {
            std::string refused;  // already reported by the render thread's own spec
            applyThreadSpec(kThreadRenderWorker, realtime, refused);
            loop();
        });
    }
}

RowPool::~RowPool() {
    {
        std::lock_guard<std::mutex> g(m_);
        stop_ = true;
        ++generation_;
    }
    wake_.notify_all();
    for (auto& t : workers_)
        t.join();
}

void RowPool::run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept {
    if (n_ == 1) {
        fn(ctx, 0, rows);
        return;
    }
    {
        std::lock_guard<std::mutex> g(m_);
        rows_ = rows;
        // Eight chunks a thread: small enough to even out a thread held up for a while, large
        // enough that taking one costs nothing against its rows.
        chunk_ = std::max(1, rows / (8 * n_));
        next_.store(0, std::memory_order_relaxed);
        fn_ = fn;
        ctx_ = ctx;
        pending_ = n_ - 1;
        ++generation_;
    }
    wake_.notify_all();
    work();
    std::unique_lock<std::mutex> l(m_);
    done_.wait(l, [this] { return pending_ == 0; });
}

void RowPool::work() noexcept {
    for (;;) {
        const int y0 = next_.fetch_add(chunk_, std::memory_order_relaxed);
        if (y0 >= rows_) return;
        fn_(ctx_, y0, std::min(rows_, y0 + chunk_));
    }
}

void RowPool::loop() {
    unsigned long seen = 0;
    for (;;) {
        std::unique_lock<std::mutex> l(m_);
        wake_.wait(l, [&] { return generation_ != seen; });
        seen = generation_;
        if (stop_) return;
        l.unlock();
        work();
        l.lock();
        if (--pending_ == 0) done_.notify_one();
    }
}

}  // namespace nvs::rt
