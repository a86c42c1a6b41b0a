// nvstim replay SCENARIO_DIR [--check|--bless] (docs/design.md §7, §9).
#include <unistd.h>

#include <cstdio>
#include <filesystem>

#include "rt/cli/commands.h"
#include "rt/replay/replay.h"
#include "sim/core/error.h"

namespace nvs::cli {

int runReplay(const ReplayOptions& opts) {
    const std::filesystem::path self = std::filesystem::read_symlink("/proc/self/exe");
    std::string dir = opts.scenarioDir;
    while (dir.size() > 1 && dir.back() == '/')
        dir.pop_back();
    if (opts.bless) {
        rt::blessScenario(dir, self);
        std::printf("replay %s: blessed (expectations written to %s/expected)\n", dir.c_str(),
                    dir.c_str());
        return kExitOk;
    }
    if (opts.check) {
        const rt::ReplayResult r = rt::checkScenario(dir, self);
        std::fputs(r.report.c_str(), stdout);
        return r.passed ? kExitOk : kExitFailure;
    }
    // Plain replay: run it into a private folder of its own (two replays never share one) and
    // say where the frames are.
    const auto work = rt::makeReplayTempDir();
    const auto frames = rt::replayScenario(dir, self, work);
    std::printf("replay %s: frames in %s, metadata in %s\n", dir.c_str(), frames.c_str(),
                (work / "meta.jsonl").c_str());
    return kExitOk;
}

}  // namespace nvs::cli
