// nvstim replay SCENARIO [--check|--bless|--out DIR] (docs/design.md §7, §9).
// SCENARIO is a scenario folder, or the bare name of a shipped one (rt/cli/data_dirs.h).
// A plain replay runs the scenario under the sim clock and says how many frames it made; the
// frames and metadata are kept only in the folder --out names. Without it they go to a private
// temporary folder that is removed before the command ends, on success, on failure, and on
// SIGINT/SIGTERM/SIGHUP/SIGQUIT (held while the replay runs, then delivered).
#include <unistd.h>

#include <cstdio>
#include <filesystem>
#include <optional>
#include <system_error>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/replay/replay.h"
#include "sim/core/error.h"
#include "sim/core/output_file.h"

namespace nvs::cli {

namespace {
namespace fs = std::filesystem;

// The replay's private folder, removed with everything in it when this goes.
struct RemovedAtEnd {
    fs::path path;
    ~RemovedAtEnd() {
        std::error_code ec;
        fs::remove_all(path, ec);
    }
};

// The frames a replay wrote: frames/ (a rig: CHANNEL/frames/ of each channel).
long long framesIn(const fs::path& work) {
    long long n = 0;
    std::error_code ec;
    for (fs::recursive_directory_iterator it(work, ec), end; !ec && it != end; it.increment(ec))
        n += it->path().extension() == ".pgm" ? 1 : 0;
    return n;
}

// --out DIR: a new folder, or an empty one (a replay never mixes its frames with others).
fs::path keptFolder(const std::string& dir) {
    std::error_code ec;
    if (fs::exists(dir, ec) && (!fs::is_directory(dir, ec) || !fs::is_empty(dir, ec))) {
        throw SetupError("--out " + dir + ": must be a new or an empty folder");
    }
    fs::create_directories(dir, ec);
    if (ec) throw SetupError("--out " + dir + ": cannot create: " + ec.message());
    return dir;
}

}  // namespace

int runReplay(const ReplayOptions& opts) {
    const fs::path self = fs::read_symlink("/proc/self/exe");
    std::string dir = resolveScenario(opts.scenarioDir, scenariosDir(resolveDataDirs()));
    while (dir.size() > 1 && dir.back() == '/')
        dir.pop_back();
    if (opts.bless) {
        rt::blessScenario(dir, self);
        std::printf("replay %s: blessed (expectations written to %s/expected)\n", dir.c_str(),
                    dir.c_str());
        return kExitOk;
    }
    // A signal while the child runs is held until the private folder is gone (declared first:
    // it ends last).
    const SignalHold hold;
    if (opts.check) {
        const rt::ReplayResult r = rt::checkScenario(dir, self);
        std::fputs(r.report.c_str(), stdout);
        return r.passed ? kExitOk : kExitFailure;
    }
    if (opts.out) {
        const fs::path kept = keptFolder(*opts.out);
        (void)rt::replayScenario(dir, self, kept);
        std::printf("replay %s: %lld frames in %s (frames/, meta.jsonl, run.log)\n", dir.c_str(),
                    framesIn(kept), kept.c_str());
        return kExitOk;
    }
    // Plain replay: a private folder of its own (two replays never share one), removed at the
    // end; the count of frames says the run went through.
    const RemovedAtEnd work{rt::makeReplayTempDir()};
    (void)rt::replayScenario(dir, self, work.path);
    std::printf("replay %s: %lld frames replayed, none kept (--out DIR keeps them)\n", dir.c_str(),
                framesIn(work.path));
    return kExitOk;
}

}  // namespace nvs::cli
