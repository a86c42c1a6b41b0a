#pragma once
// A fixed pool of worker threads that splits the renderer's rows (sim/render's RowExecutor).
// sim/ has no threads (DESIGN §2); the runtime owns them. The calling thread takes the first
// share; workers are created at setup and woken per frame: nothing is allocated per frame.

#include <condition_variable>
#include <mutex>
#include <thread>
#include <vector>

#include "sim/render/renderer.h"

namespace nvs::rt {

class RowPool final : public render::RowExecutor {
  public:
    // `threads` ≥ 1 in total, the caller included.
    explicit RowPool(int threads);
    ~RowPool() override;
    RowPool(const RowPool&) = delete;
    RowPool& operator=(const RowPool&) = delete;

    void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept override;
    int threads() const { return n_; }

  private:
    void loop(int index);

    int n_;
    std::vector<std::thread> workers_;
    std::mutex m_;
    std::condition_variable wake_, done_;
    unsigned long generation_ = 0;
    int pending_ = 0;
    bool stop_ = false;
    int rows_ = 0;
    void (*fn_)(void*, int, int) = nullptr;
    void* ctx_ = nullptr;
};

}  // namespace nvs::rt
