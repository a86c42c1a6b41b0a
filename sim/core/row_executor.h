#pragma once
// Row executors: how sim/ code hands out independent ranges of work (image rows, bands of rows)
// to threads it does not own. sim/ starts no threads (docs/design.md §2); the runtime passes an
// executor backed by its pool (rt/render_stage/row_pool.h), tests and tools the serial one.

namespace nvs {

class RowExecutor {
  public:
    virtual ~RowExecutor() = default;
    // Calls fn(ctx, y0, y1) over disjoint ranges covering [0, rows), maybe concurrently, and
    // returns when all are done.
    virtual void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept = 0;
};

class SerialExecutor final : public RowExecutor {
  public:
    void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept override {
        fn(ctx, 0, rows);
    }
};

// Calls f(i) for every i in [0, n) through `exec` (f must be safe to call concurrently for
// different i). No allocation: f is passed by address.
template <class F>
void forEachIndex(RowExecutor& exec, int n, F& f) noexcept {
    exec.run(
        n,
        [](void* ctx, int i0, int i1) {
            F& fn = *static_cast<F*>(ctx);
            for (int i = i0; i < i1; ++i)
                fn(i);
        },
        &f);
}

}  // namespace nvs
