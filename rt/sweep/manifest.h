#pragma once
// The manifest: the grid of a spec (spec.h) expanded into jobs, one JSON object a line
// (docs/contracts.md, "sweep"), in the sweep's folder as manifest.jsonl. Everything a job needs
// is on its line, so that a Slurm array task (`nvstim sweep --task I --manifest FILE`) runs
// job I from the file alone.

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rt/sweep/spec.h"

namespace nvs::rt::sweep {

struct Job {
    std::int64_t index = 0;
    JobKind kind = JobKind::Run;
    std::string dir;  // the job's folder, absolute (<out>/jobs/NNNNNN)
    std::string cwd;  // where the job's program runs (the sweep's working folder)
    std::string scenario, scenarioPath;  // as written, resolved ("" where the grid has none)
    std::string preset, presetArg;       // likewise ("": the scenario's own)
    std::optional<std::uint64_t> seed;   // none: the scenario's own
    std::vector<std::pair<std::string, std::string>> set;  // the [set] axes' values
    std::int64_t frames = 0;
    double timeout_s = 3600.0;
    bool keepFrames = false;
    // The program's arguments: run, after the nvstim binary ("run", SCENARIO, ...); command,
    // the whole command line with its placeholders replaced.
    std::vector<std::string> argv;
};

// The grid in its order: scenarios × presets × [set] (first key outermost) × seeds, the last
// varying fastest. `outDir` and `cwd` absolute. Throws SetupError (a command's placeholder).
std::vector<Job> expandJobs(const SweepSpec& spec, const std::filesystem::path& outDir,
                            const std::filesystem::path& cwd);

// The file a job of kind run is given as its scenario: with a seed, the seeded copy in its
// folder (seeded_scenario.h); else the scenario itself.
std::string runScenarioArg(const Job& job);

// One manifest line (no newline) and back. parseJob throws SetupError naming `where`.
std::string jobLine(const Job& job);
Job parseJob(const std::string& line, const std::string& where);

// The manifest's text (one line a job) and its jobs read from a file.
std::string manifestText(const std::vector<Job>& jobs);
std::vector<Job> readManifest(const std::filesystem::path& file);

// The job folder's name: jobs/000042.
std::string jobDirName(std::int64_t index);

}  // namespace nvs::rt::sweep
