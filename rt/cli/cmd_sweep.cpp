// nvstim sweep: a grid of scenarios, camera presets, settings and seeds run as one table
// (docs/sweep.md, docs/contracts.md "sweep").
//
//   nvstim sweep SPEC --out DIR [--jobs N] [--var NAME=VALUE]... [--dry-run]
//   nvstim sweep SPEC --out DIR --slurm [--sbatch-args "..."] [--jobs N] [--no-wait]
//   nvstim sweep --task I --manifest FILE      one job (what a worker and an array task run)
//   nvstim sweep --gather DIR                  the table and plots again from the results

#include <filesystem>
#include <system_error>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/sweep/gather.h"
#include "rt/sweep/process.h"
#include "rt/sweep/sweep.h"
#include "rt/sweep/task.h"
#include "sim/core/error.h"

namespace nvs::cli {

namespace fs = std::filesystem;

static_assert(rt::sweep::kSweepJobFailed == kExitFailure && rt::sweep::kSweepUsage == kExitUsage &&
              rt::sweep::kSweepInterrupted == kExitInterrupted);

namespace {

// This binary: the workers and the jobs of kind run are it.
fs::path selfExe() {
    std::error_code ec;
    const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
    if (ec) throw SetupError("sweep: cannot find this program (/proc/self/exe): " + ec.message());
    return exe;
}

void refuse(bool given, const char* option, const char* mode) {
    if (given) throw SetupError(std::string(option) + " does not go with " + mode);
}

}  // namespace

int runSweep(const SweepOptions& opts) {
    const DataDirs dirs = resolveDataDirs();
    if (opts.gather) {
        refuse(opts.spec.has_value(), "SPEC", "--gather");
        refuse(opts.out.has_value(), "--out", "--gather");
        refuse(opts.task.has_value() || opts.manifest.has_value(), "--task/--manifest", "--gather");
        refuse(opts.slurm, "--slurm", "--gather");
        return rt::sweep::gatherOnly(*opts.gather, rt::sweep::plotScriptFor(dirs.config), stderr);
    }
    if (opts.task || opts.manifest) {
        if (!opts.task || !opts.manifest) throw SetupError("--task and --manifest go together");
        refuse(opts.spec.has_value(), "SPEC", "--task");
        refuse(opts.out.has_value(), "--out", "--task");
        refuse(opts.slurm, "--slurm", "--task");
        std::atomic<bool>& stop = rt::sweep::installSweepStopSignals();
        return rt::sweep::runTask(*opts.manifest, *opts.task, selfExe(), &stop);
    }
    if (!opts.spec)
        throw SetupError("sweep: give SPEC and --out DIR, --task with --manifest, or --gather DIR");
    if (!opts.out) throw SetupError("sweep " + *opts.spec + ": --out DIR is required");
    refuse(opts.sbatchArgs.has_value() && !opts.slurm, "--sbatch-args", "a run without --slurm");
    refuse(opts.noWait && !opts.slurm, "--no-wait", "a run without --slurm");
    rt::sweep::SweepRequest req;
    req.spec = *opts.spec;
    req.out = *opts.out;
    req.vars = opts.vars;
    req.jobs = opts.jobs.value_or(1);
    req.jobsGiven = opts.jobs.has_value();
    req.slurm = opts.slurm;
    req.sbatchArgs = opts.sbatchArgs.value_or("");
    req.noWait = opts.noWait;
    req.dryRun = opts.dryRun;
    req.nvstim = selfExe();
    req.scenariosDir = scenariosDir(dirs);
    req.plotScript = rt::sweep::plotScriptFor(dirs.config);
    return rt::sweep::runSweep(req, stderr);
}

}  // namespace nvs::cli
