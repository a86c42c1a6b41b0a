#pragma once
// A fixed pool of worker threads that splits the renderer's rows (sim/render's RowExecutor).
// sim/ has no threads (DESIGN §2); the runtime owns them. The calling thread works too; workers
// are created at setup and woken per frame: nothing is allocated per frame. Rows are handed out
// in chunks from a shared counter, not in fixed shares: the camera thread and the rest of the
// machine take cores from the render threads at random, and a thread held up then leaves its
// rows to the others instead of making them wait (each row's result does not depend on which
// thread computes it, sim/render).

#include <atomic>
#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "sim/render/renderer.h"

namespace nvs::rt {

class RowPool final : public render::RowExecutor {
  public:
    // `threads` ≥ 1 in total, the caller included. With `realtime` the workers take their
    // entry of the thread table (rt/clock/threads.h: SCHED_FIFO, the render thread's priority).
    explicit RowPool(int threads, bool realtime = false);
    ~RowPool() override;
    RowPool(const RowPool&) = delete;
    RowPool& operator=(const RowPool&) = delete;

    void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept override;
    int threads() const { return n_; }

  private:
    void loop();
    void work() noexcept;  // takes chunks of rows until none is left

    int n_;
    std::vector<std::thread> workers_;
    std::mutex m_;
    std::condition_variable wake_, done_;
    unsigned long generation_ = 0;
    int pending_ = 0;
    bool stop_ = false;
    int rows_ = 0, chunk_ = 1;
    std::atomic<int> next_{0};
    void (*fn_)(void*, int, int) = nullptr;
    void* ctx_ = nullptr;
};

}  // namespace nvs::rt
