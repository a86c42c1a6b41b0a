#pragma once
// Running a sweep's jobs here: N worker processes at a time, each `nvstim sweep --task I
// --manifest FILE` (the same binary), and a progress line on `progress` at most once a second
// (into a file or pipe only when a job has finished, or after 30 s):
//   nvstim sweep: 12/24 done (1 failed), 0.85 jobs/s, 14 s left
// A worker that ends without writing its job's result (killed, crashed) is recorded as a
// failed job with its exit status and the tail of its log (jobs/NNNNNN/task.log).

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "rt/sweep/manifest.h"

namespace nvs::rt::sweep {

// The progress of a sweep: the line above, printed at most once a second (or at once with
// force); `total` counts every job, `done` the ones finished (also those of earlier runs).
class Progress {
  public:
    Progress(std::FILE* out, std::int64_t total, std::int64_t doneBefore);
    void update(std::int64_t doneNow, std::int64_t failed, bool force);

  private:
    std::FILE* out_;
    std::int64_t total_, before_;
    double start_s_, last_s_ = -1.0;
    std::int64_t lastDone_ = -1;
    bool tty_;
};

struct PoolResult {
    std::int64_t ran = 0, failed = 0;
    bool interrupted = false;
};

// Runs the jobs of `todo` (indices into `jobs`) with `workers` processes at a time.
PoolResult runPool(const std::vector<Job>& jobs, const std::vector<std::int64_t>& todo, int workers,
                   const std::filesystem::path& nvstim, const std::filesystem::path& manifest,
                   std::FILE* progress, std::atomic<bool>& stop);

}  // namespace nvs::rt::sweep
