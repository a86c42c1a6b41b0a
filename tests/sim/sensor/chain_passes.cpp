// Wall time of the camera chain per field and of each of its executor runs (passes), on one
// thread and on a RowPool of two, for finding where the two-thread split loses time. Not a
// test, run by hand:
//   nvs_chain_passes CONFIG_DIR [FIELDS]

#include <time.h>

#include <algorithm>
#include <cstdint>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "rt/render_stage/row_pool.h"
#include "sim/core/gamma_table.h"
#include "sim/core/row_executor.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"
#include "tests/sim/sensor/chain_inputs.h"

namespace {
double wall_s() {
    timespec t{};
    clock_gettime(CLOCK_MONOTONIC, &t);
    return static_cast<double>(t.tv_sec) + 1e-9 * static_cast<double>(t.tv_nsec);
}

// Times every run() of the executor it wraps, and the gaps between them (serial work).
class TimedExecutor final : public nvs::RowExecutor {
  public:
    explicit TimedExecutor(nvs::RowExecutor& inner) : inner_(inner) {}
    void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept override {
        const double t0 = wall_s();
        if (k_ < kMax) gap_[k_] += t0 - last_;
        inner_.run(rows, fn, ctx);
        last_ = wall_s();
        if (k_ < kMax) pass_[k_] += last_ - t0;
        ++k_;
    }
    void startField() {
        k_ = 0;
        last_ = wall_s();
    }
    void endField() {
        tail_ += wall_s() - last_;
        passes_ = k_;
    }
    void clear() {
        std::fill(gap_, gap_ + kMax, 0.0);
        std::fill(pass_, pass_ + kMax, 0.0);
        tail_ = 0.0;
    }
    void print(int fields) const {
        for (int k = 0; k < std::min(passes_, kMax); ++k)
            std::printf("  pass %d: serial before %.3f ms, pass %.3f ms\n", k,
                        1e3 * gap_[k] / fields, 1e3 * pass_[k] / fields);
        std::printf("  serial after the last pass %.3f ms\n", 1e3 * tail_ / fields);
    }

  private:
    static constexpr int kMax = 16;
    nvs::RowExecutor& inner_;
    double gap_[kMax] = {}, pass_[kMax] = {}, tail_ = 0.0, last_ = 0.0;
    int k_ = 0, passes_ = 0;
};
}  // namespace

int main(int argc, char** argv) {
    nvs::sensor::ChainToolArgs args;
    if (!nvs::sensor::chainToolArgs(argc, argv, "nvs_chain_passes", &args)) return 2;
    nvs::rt::RowPool pool(2);
    nvs::SerialExecutor serial;
    for (const bool lamp : {false, true}) {
        const nvs::ImageF lpe = nvs::sensor::chainTimingInput(args.cam, lamp);
        for (const int threads : {1, 2}) {
            nvs::GammaTableCache tables;
            nvs::sensor::IiccdChain chain(args.cam, 1, args.config, tables);
            TimedExecutor timed(threads == 1 ? static_cast<nvs::RowExecutor&>(serial)
                                             : static_cast<nvs::RowExecutor&>(pool));
            chain.setExecutor(&timed);
            for (int i = 0; i < 10; ++i)
                chain.process(lpe.cview());
            timed.clear();
            std::vector<double> t_s;
            for (int i = 0; i < args.fields; ++i) {
                timed.startField();
                const double t0 = wall_s();
                chain.process(lpe.cview());
                t_s.push_back(wall_s() - t0);
                timed.endField();
            }
            std::sort(t_s.begin(), t_s.end());
            std::printf("%-8s %d thread(s): median %.3f ms  min %.3f ms\n",
                        lamp ? "lamp" : "uniform", threads, 1e3 * t_s[t_s.size() / 2],
                        1e3 * t_s[0]);
            timed.print(args.fields);
        }
    }
    return 0;
}
