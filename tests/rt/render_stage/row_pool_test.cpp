// RowPool: every row of every run exactly once, whatever threads take them and however late a
// worker wakes; runs back to back (the camera chain's pattern) and with pauses between them
// (workers asleep).

#include "rt/render_stage/row_pool.h"

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <thread>
#include <vector>

namespace nvs::rt {
namespace {

struct Counts {
    std::vector<std::atomic<int>> hits;
    explicit Counts(int n) : hits(static_cast<std::size_t>(n)) {}
};

void countRows(void* ctx, int y0, int y1) {
    auto* c = static_cast<Counts*>(ctx);
    for (int y = y0; y < y1; ++y)
        c->hits[static_cast<std::size_t>(y)].fetch_add(1, std::memory_order_relaxed);
}

// Runs `runs` jobs of varying size on `pool`; each row of each job must be hit once.
void expectEveryRowOnce(RowPool& pool, int runs, bool pauses) {
    for (int r = 0; r < runs; ++r) {
        const int rows = 1 + (r * 7) % 40;  // 1 … 40 rows, chunks of one row and more
        Counts counts(rows);
        pool.run(rows, countRows, &counts);
        for (int y = 0; y < rows; ++y)
            ASSERT_EQ(counts.hits[static_cast<std::size_t>(y)].load(), 1)
                << "run " << r << " row " << y << " of " << rows;
        if (pauses && r % 50 == 0) std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
}

TEST(RowPool, EveryRowOnceInRunsBackToBack) {
    for (int threads : {1, 2, 3}) {
        RowPool pool(threads);
        expectEveryRowOnce(pool, 3000, false);
    }
}

TEST(RowPool, EveryRowOnceWithWorkersAsleepBetweenRuns) {
    RowPool pool(3);
    expectEveryRowOnce(pool, 500, true);
}

TEST(RowPool, NoRowsCallsNothing) {
    RowPool pool(2);
    Counts counts(1);
    pool.run(0, countRows, &counts);
    EXPECT_EQ(counts.hits[0].load(), 0);
}

}  // namespace
}  // namespace nvs::rt
