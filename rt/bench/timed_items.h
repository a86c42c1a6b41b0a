#pragma once
// `nvstim bench`'s per-stage items on Google Benchmark: each item is registered with
// benchmark::RegisterBenchmark and run by benchmark::RunSpecifiedBenchmarks; a reporter
// (timed_items.cpp) collects the results into nvstim's JSON keys (docs/contracts.md, "bench").
// Each iteration is timed on its own (manual time), so the distribution (min, p50, p99) of the
// per-iteration times is reported, not only Google Benchmark's mean.

#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <utility>
#include <vector>

#include "rt/run/run.h"  // jsonEscape

namespace nvs::rt::bench {

struct TimedItem {
    std::string name;
    std::string what;
    std::optional<double> target_s;  // budget for p50 (absent: a reference figure)
    double minTime_s = 1.0;          // Google Benchmark's min time (of the manual time)
    // Called once before the first timed iteration (untimed): heavy setup, only for the items
    // the filter keeps.
    std::function<void()> setup;
    std::function<void()> prepare;    // before each timed iteration, untimed (may be empty)
    std::function<void()> iteration;  // one timed iteration
    // Called once after timing: adds figures (rays/s, pe/px, ...) to `extra`.
    std::function<void(TimedItem&)> after;

    // Results.
    bool ran = false;
    std::int64_t iterations = 0;
    double min_s = 0.0, p50_s = 0.0, p99_s = 0.0, mean_s = 0.0;
    std::vector<std::pair<std::string, double>> extra;
    std::string note;               // one line `after` may add (e.g. the OpenGL renderer used)
    std::string error;              // why setup failed (the item then did not run)
    std::vector<double> samples_s;  // the reported trial's per-iteration times
    // The calling thread's CPU time per iteration (CLOCK_THREAD_CPUTIME_ID): for one-thread
    // items the core's share, less disturbed by other load than the wall time.
    std::vector<double> cpuSamples_s;
    double cpuP50_s = 0.0;
};

// What Google Benchmark reports about the machine (0 when no item ran).
struct MachineInfo {
    double mhz = 0.0;
};

// The calling thread's CPU time [s] (CLOCK_THREAD_CPUTIME_ID).
double threadCpu_s() noexcept;

// Whether `name` is kept by `filter`: comma-separated texts, kept if it contains any of them
// (every name without a filter).
bool filterKeeps(const std::optional<std::string>& filter, const std::string& name);

// Registers every item and runs those `filter` keeps (filterKeeps; all without one), filling
// their results; progress and a table on stderr.
MachineInfo runTimedItems(std::vector<std::unique_ptr<TimedItem>>& items,
                          const std::optional<std::string>& filter);

// One item as nvstim's JSON object: name, what, iterations, min_s, p50_s, p99_s, mean_s,
// target_s and meets_target (null without a target), then the extra keys, then note if any.
std::string timedItemJson(const TimedItem& item);

}  // namespace nvs::rt::bench
