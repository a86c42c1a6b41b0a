#pragma once
// `nvstim sweep` (docs/sweep.md): a spec's grid expanded into a manifest, run here with N
// worker processes or as one Slurm job array, and gathered into one table with plots.
//
// Exit status: 0 every job succeeded; 1 a job failed, timed out or left no result (the table
// is written, each failure in it), or sbatch/squeue failed; 2 usage or setup error (bad spec,
// --out refused: nothing written); 8 interrupted by SIGINT/SIGTERM (the jobs that finished are
// kept and gathered; the same command resumes).

#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

namespace nvs::rt::sweep {

inline constexpr int kSweepOk = 0;
inline constexpr int kSweepJobFailed = 1;
inline constexpr int kSweepUsage = 2;
inline constexpr int kSweepInterrupted = 8;

struct SweepRequest {
    std::filesystem::path spec;
    std::filesystem::path out;
    std::vector<std::string> vars;  // NAME=VALUE
    int jobs = 1;                   // local workers
    bool jobsGiven = false;         // --jobs given (with --slurm: the array's %N)
    bool slurm = false;
    std::string sbatchArgs;
    bool noWait = false;
    bool dryRun = false;  // print the manifest, run nothing, write nothing
    // Resolved by the command line:
    std::filesystem::path nvstim;        // this binary (/proc/self/exe)
    std::filesystem::path scenariosDir;  // the shipped scenarios
    std::filesystem::path plotScript;    // sweep_plots.py ("" : no plots)
};

// Runs (or submits) the sweep; progress and notes to `log`. Throws SetupError.
int runSweep(const SweepRequest& req, std::FILE* log);

// `nvstim sweep --gather DIR`: the table and plots again from the result files.
int gatherOnly(const std::filesystem::path& dir, const std::filesystem::path& plotScript,
               std::FILE* log);

}  // namespace nvs::rt::sweep
