#include "rt/render_stage/row_pool.h"

#include <pthread.h>

namespace nvs::rt {

RowPool::RowPool(int threads) : n_(threads < 1 ? 1 : threads) {
    for (int i = 1; i < n_; ++i) {
        workers_.emplace_back([this, i] { loop(i); });
        pthread_setname_np(workers_.back().native_handle(), "nvs-render-w");
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
        fn_ = fn;
        ctx_ = ctx;
        pending_ = n_ - 1;
        ++generation_;
    }
    wake_.notify_all();
    fn(ctx, 0, rows / n_);
    std::unique_lock<std::mutex> l(m_);
    done_.wait(l, [this] { return pending_ == 0; });
}

void RowPool::loop(int index) {
    unsigned long seen = 0;
    for (;;) {
        std::unique_lock<std::mutex> l(m_);
        wake_.wait(l, [&] { return generation_ != seen; });
        seen = generation_;
        if (stop_) return;
        const int rows = rows_;
        auto* fn = fn_;
        void* ctx = ctx_;
        l.unlock();
        fn(ctx, rows * index / n_, rows * (index + 1) / n_);
        l.lock();
        if (--pending_ == 0) done_.notify_one();
    }
}

}  // namespace nvs::rt
