#pragma once
// A sweep as ONE Slurm job array (docs/sweep.md, "Slurm"): the sbatch script
// DIR/slurm/sweep.sbatch has one array task per job still to run, its index the manifest's:
//   #SBATCH --array=0-23[%N]
//   exec NVSTIM sweep --task "$SLURM_ARRAY_TASK_ID" --manifest DIR/manifest.jsonl
// each task's output in DIR/slurm/task-<index>.out. The script is submitted with
// `sbatch --parsable [--sbatch-args...]`; the sweep then polls `squeue` until the array has
// left the queue, printing its progress from the result files, and gathers.

#include <atomic>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "rt/sweep/manifest.h"

namespace nvs::rt::sweep {

// "0-3,7,9-11" for the sorted indices.
std::string arrayRanges(const std::vector<std::int64_t>& indices);

// The script's text. `throttle`: at most this many tasks at once (%N), none when absent.
std::string sbatchScript(const std::string& name, const std::vector<std::int64_t>& todo,
                         std::optional<int> throttle, const std::filesystem::path& nvstim,
                         const std::filesystem::path& dir, const std::filesystem::path& cwd);

// `--sbatch-args "..."` split at blanks (single and double quotes group, as a shell does).
std::vector<std::string> splitArgs(const std::string& text);

// Submits `script`; returns the job id. Throws std::runtime_error with sbatch's message.
std::string submitArray(const std::filesystem::path& script, const std::vector<std::string>& args);

// Waits until job `id` has left the queue (squeue no longer lists it), printing progress from
// the jobs' result files. Returns false when stopped by `stop` (the array is cancelled with
// scancel) . Throws std::runtime_error when squeue keeps failing for a minute.
bool waitForArray(const std::string& id, const std::vector<Job>& jobs,
                  const std::vector<std::int64_t>& todo, std::FILE* progress,
                  std::atomic<bool>& stop);

}  // namespace nvs::rt::sweep
