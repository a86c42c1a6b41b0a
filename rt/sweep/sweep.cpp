#include "rt/sweep/sweep.h"

#include <stdexcept>

#include "rt/sweep/folder.h"
#include "rt/sweep/gather.h"
#include "rt/sweep/manifest.h"
#include "rt/sweep/pool.h"
#include "rt/sweep/process.h"
#include "rt/sweep/slurm.h"
#include "rt/sweep/spec.h"
#include "rt/sweep/task.h"
#include "sim/core/error.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

namespace {

// Larger grids are a mistake more often than not; a manifest line is about 500 bytes.
constexpr std::size_t kMaxJobs = 1000000;

int finish(const fs::path& dir, const fs::path& plotScript, bool interrupted, std::FILE* log) {
    const GatherCounts c = gatherSweep(dir, plotScript, log);
    std::fprintf(log, "nvstim sweep: %lld jobs: %lld ok, %lld failed, %lld without a result; %s\n",
                 static_cast<long long>(c.ok + c.failed + c.missing), static_cast<long long>(c.ok),
                 static_cast<long long>(c.failed), static_cast<long long>(c.missing),
                 (dir / "results.csv").string().c_str());
    if (interrupted) return kSweepInterrupted;
    return c.failed + c.missing > 0 ? kSweepJobFailed : kSweepOk;
}

}  // namespace

int runSweep(const SweepRequest& req, std::FILE* log) {
    const SweepSpec spec = loadSpec(req.spec, req.scenariosDir, req.vars);
    const fs::path out = fs::absolute(req.out).lexically_normal();
    const std::vector<Job> jobs = expandJobs(spec, out, fs::current_path());
    if (jobs.size() > kMaxJobs) {
        throw SetupError(spec.file.string() + ": the grid has " + std::to_string(jobs.size()) +
                         " jobs, more than " + std::to_string(kMaxJobs));
    }
    const std::string manifest = manifestText(jobs);
    if (req.dryRun) {
        std::fputs(manifest.c_str(), stdout);
        return kSweepOk;
    }
    const SweepInfo info = sweepInfo(spec, static_cast<std::int64_t>(jobs.size()));
    const FolderState state = prepareFolder(out, info, manifest);
    std::vector<std::int64_t> todo;
    for (const Job& j : jobs)
        if (readResult(j).stringOr("status", "") != "ok") todo.push_back(j.index);
    if (state == FolderState::Resumed) {
        std::fprintf(log, "nvstim sweep: resuming %s: %lld of %lld jobs done, %lld to run\n",
                     out.string().c_str(), static_cast<long long>(jobs.size() - todo.size()),
                     static_cast<long long>(jobs.size()), static_cast<long long>(todo.size()));
    }
    std::atomic<bool>& stop = installSweepStopSignals();
    const fs::path manifestFile = out / "manifest.jsonl";

    if (req.slurm) {
        if (todo.empty()) return finish(out, req.plotScript, false, log);
        fs::create_directories(out / "slurm");
        const fs::path script = out / "slurm" / "sweep.sbatch";
        writeFileAtomic(script,
                        sbatchScript(spec.name, todo,
                                     req.jobsGiven ? std::optional<int>(req.jobs) : std::nullopt,
                                     req.nvstim, out, fs::current_path()));
        std::string id;
        try {
            id = submitArray(script, splitArgs(req.sbatchArgs));
        } catch (const std::runtime_error& e) {
            std::fprintf(log, "nvstim sweep: %s\n", e.what());
            return kSweepJobFailed;
        }
        std::fprintf(log, "nvstim sweep: submitted job array %s (%zu tasks: %s)\n", id.c_str(),
                     todo.size(), script.string().c_str());
        if (req.noWait) {
            std::fprintf(log, "nvstim sweep: when it has run: nvstim sweep --gather %s\n",
                         out.string().c_str());
            return kSweepOk;
        }
        bool finished = false;
        try {
            finished = waitForArray(id, jobs, todo, log, stop);
        } catch (const std::runtime_error& e) {
            std::fprintf(log,
                         "nvstim sweep: %s (the array may still run: nvstim sweep --gather %s)\n",
                         e.what(), out.string().c_str());
            return kSweepJobFailed;
        }
        return finish(out, req.plotScript, !finished, log);
    }

    const PoolResult r = runPool(jobs, todo, req.jobs, req.nvstim, manifestFile, log, stop);
    return finish(out, req.plotScript, r.interrupted, log);
}

int gatherOnly(const fs::path& dir, const fs::path& plotScript, std::FILE* log) {
    return finish(fs::absolute(dir).lexically_normal(), plotScript, false, log);
}

}  // namespace nvs::rt::sweep
