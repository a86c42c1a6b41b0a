#pragma once
// A fixed pool of worker threads that splits the renderer's rows (sim/render's RowExecutor).
// sim/ has no threads (docs/design.md §2); the runtime owns them. The calling thread works too;
// workers are created at setup and woken per frame: nothing is allocated per frame. Rows are handed
// out in chunks from a shared counter, not in fixed shares: the camera thread and the rest of the
// machine take cores from the render threads at random, and a thread held up then leaves its
// rows to the others instead of making them wait (each row's result does not depend on which
// thread computes it, sim/render). The caller returns as soon as every chunk is done: a worker
// that has not woken by then (a loaded machine) is not waited for, and when it wakes it finds
// that run's chunks gone (each claim carries the run's number). Between runs a worker, and the
// caller waiting for the last chunks, spin for a few tens of microseconds before they sleep:
// the camera chain hands out six runs a field, back to back, and a futex wake-up for each was a
// large part of its time on two threads.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <mutex>
#include <thread>
#include <vector>

#include "rt/clock/threads.h"
#include "sim/render/renderer.h"

namespace nvs::rt {

class RowPool final : public render::RowExecutor {
  public:
    // `threads` ≥ 1 in total, the caller included. With `realtime` the workers take their
    // entry of the thread table (rt/clock/threads.h: SCHED_FIFO, the render thread's priority).
    // `worker`: the workers' entry of the thread table (the render's, or the camera's).
    explicit RowPool(int threads, bool realtime = false, ThreadId worker = kThreadRenderWorker);
    ~RowPool() override;
    RowPool(const RowPool&) = delete;
    RowPool& operator=(const RowPool&) = delete;

    void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept override;
    int threads() const { return n_; }

  private:
    // One run as a thread saw it when it joined (copied under m_).
    struct Job {
        std::uint32_t generation = 0;
        int rows = 0, chunk = 1, chunks = 0;
        void (*fn)(void*, int, int) = nullptr;
        void* ctx = nullptr;
    };
    void loop();
    void work(const Job& job) noexcept;  // takes chunks of the job's rows until none is left

    int n_;
    std::vector<std::thread> workers_;
    std::mutex m_;
    std::condition_variable wake_, done_;
    Job job_;  // the current run (under m_)
    bool stop_ = false;
    int sleepers_ = 0;                         // workers waiting on wake_ (under m_)
    std::atomic<std::uint32_t> published_{0};  // job_.generation, for the spinning workers
    // The next chunk to take: the run's number in the high 32 bits, the chunk in the low ones
    // (a thread of an earlier run cannot take a chunk of this one).
    std::atomic<std::uint64_t> next_{0};
    std::atomic<int> finished_{0};  // chunks of the current run done
};

}  // namespace nvs::rt
