#pragma once
// One job of a manifest, run to its end (`nvstim sweep --task I --manifest FILE`: what a local
// worker and a Slurm array task run). The job's program runs as a child; its exit status, its
// stderr's tail and its wall time are recorded in the job's folder as result.json, written
// under a temporary name and renamed, so that a result is whole or absent:
//   {"index":I,"status":"ok"|"failed"|"timeout","exit_status":N,"wall_s":T,"host":"...",
//    "error":"stderr tail","metrics":{...}}
// A job that failed is recorded, not fatal: the sweep goes on.

#include <atomic>
#include <cstdint>
#include <filesystem>
#include <string>

#include "rt/sweep/json.h"
#include "rt/sweep/manifest.h"

namespace nvs::rt::sweep {

// Exit status of a task: 0 the job succeeded; 1 it failed (recorded); 2 the manifest or index
// is bad (nothing recorded); 8 stopped by SIGINT/SIGTERM (nothing recorded: a resume runs it).
inline constexpr int kTaskOk = 0;
inline constexpr int kTaskJobFailed = 1;
inline constexpr int kTaskUsage = 2;
inline constexpr int kTaskInterrupted = 8;

// Runs job `index` of `manifest`; `nvstim` is the binary that runs a job of kind run.
int runTask(const std::filesystem::path& manifest, std::int64_t index,
            const std::filesystem::path& nvstim, std::atomic<bool>* stop);

// The job's result file, and writing one (atomically: a temporary, then rename).
std::filesystem::path resultPath(const Job& job);
void writeResult(const Job& job, const Json& result);
// The result of a job, or a null Json where it has none (or an unreadable one).
Json readResult(const Job& job);

// This machine's short host name.
std::string hostName();

}  // namespace nvs::rt::sweep
