#pragma once
// The sweep's output folder (docs/sweep.md, "The output folder"):
//   sweep.json      what the sweep is (the marker of a sweep folder; SweepInfo)
//   manifest.jsonl  its jobs (manifest.h)
//   jobs/NNNNNN/    each job's files and result.json (task.h)
//   results.csv, results.json, plots/, and a command's joined file (gather.h)
//   slurm/          the sbatch script and the array tasks' output (slurm.h)
// A folder is only ever written when it is new, empty, or a sweep of the same manifest (then
// the sweep resumes: the jobs that succeeded are not run again). Any other folder is refused
// and left untouched.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "rt/sweep/manifest.h"
#include "rt/sweep/spec.h"

namespace nvs::rt::sweep {

struct SweepInfo {
    std::string name;
    std::string spec;  // the spec file, absolute
    JobKind kind = JobKind::Run;
    std::int64_t jobs = 0;
    // The grid's axes, in column order: "scenario", "preset", "seed" where the spec has them,
    // then the [set] keys.
    std::vector<std::string> axes;
    std::string concat;
    int concatHeaderLines = 0;
};

SweepInfo sweepInfo(const SweepSpec& spec, std::int64_t jobs);

// How prepareFolder found the folder.
enum class FolderState { New, Resumed };

// Checks `dir` for this sweep and writes sweep.json and manifest.jsonl where it is new.
// Throws SetupError ("--out DIR: ...") where the folder is refused; nothing is written then.
FolderState prepareFolder(const std::filesystem::path& dir, const SweepInfo& info,
                          const std::string& manifest);

// Reads DIR/sweep.json; throws SetupError where DIR is not a sweep folder.
SweepInfo readInfo(const std::filesystem::path& dir);

// A value of an axis for a job ("" where the job has none).
std::string axisValue(const Job& job, const std::string& axis);

// Writes `text` to `path` under a temporary name, then renames it into place.
void writeFileAtomic(const std::filesystem::path& path, const std::string& text);

}  // namespace nvs::rt::sweep
