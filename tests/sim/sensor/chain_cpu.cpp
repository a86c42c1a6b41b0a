// CPU time of the camera chain per field, one thread, for comparing changes to the chain on a
// machine shared with other work (thread CPU time, not wall time): the PULNiX preset on a
// uniform field (1.4 pe/px) and on the same with a lamp (a disk far past full well, so the MCP
// saturates and the CCD blooms). Prints, per input, the median and least CPU time a field and
// an FNV-1a digest of the video of the last field (the same digest before and after a change
// means the same bits). Not a test, run by hand:
//   nvs_chain_cpu CONFIG_DIR [FIELDS]

#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "sim/core/gamma_table.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"
#include "tests/sim/sensor/chain_inputs.h"

namespace {
double threadCpu_s() {
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}
}  // namespace

int main(int argc, char** argv) {
    nvs::sensor::ChainToolArgs args;
    if (!nvs::sensor::chainToolArgs(argc, argv, "nvs_chain_cpu", &args)) return 2;
    for (const bool lamp : {false, true}) {
        const nvs::ImageF lpe = nvs::sensor::chainTimingInput(args.cam, lamp);
        nvs::GammaTableCache tables;
        nvs::sensor::IiccdChain chain(args.cam, 1, args.config, tables);
        for (int i = 0; i < 10; ++i)
            chain.process(lpe.cview());
        std::vector<double> t_s;
        for (int i = 0; i < args.fields; ++i) {
            const double t0 = threadCpu_s();
            chain.process(lpe.cview());
            t_s.push_back(threadCpu_s() - t0);
        }
        std::sort(t_s.begin(), t_s.end());
        std::uint64_t h = 1469598103934665603ull;
        const nvs::ImageU16& v = chain.video();
        for (int y = 0; y < v.height(); ++y)
            for (int x = 0; x < v.width(); ++x) {
                h = (h ^ v.row(y)[x]) * 1099511628211ull;
            }
        std::printf("%-8s median %.3f ms  min %.3f ms  mean_pe %.3f  video %016llx\n",
                    lamp ? "lamp" : "uniform", 1e3 * t_s[t_s.size() / 2], 1e3 * t_s[0],
                    chain.lastInfo().mean_pe, static_cast<unsigned long long>(h));
    }
    return 0;
}
