#pragma once
// End-to-end figures of `nvstim bench`: a scenario run through the real frame loop under the
// sim clock, exactly as `nvstim run SCENARIO --clock sim --frames N --output y4m:/dev/null`
// runs it (rt/run's runScenario), in a child process of its own so that its peak RSS
// (getrusage ru_maxrss of the child, from wait4) is that run's alone.
//
// Steady-state allocations: the same run twice, for warmFrames and for frames ticks; the
// difference of their operator new counts (rt/bench/alloc_count.h) is what the extra
// (frames − warmFrames) ticks allocated, setup and shutdown being the same in both.
//
// Must be called while the calling process has a single thread (fork).

#include <cstdint>
#include <filesystem>
#include <string>

#include "sim/core/paths.h"

namespace nvs::rt::bench {

struct EndToEndRequest {
    std::string name;
    std::string what;
    std::filesystem::path scenario;
    DataDirs dirs;
    int warmFrames = 20;  // the shorter run (allocation count)
    int frames = 60;      // the measured run
    double targetFields_per_s = 59.94;
};

struct EndToEndResult {
    bool ok = false;
    std::string error;       // why not ok
    int fieldsPerFrame = 1;  // 2: interlaced
    std::int64_t frames = 0;
    double elapsed_s = 0.0;
    double fields_per_s = 0.0;                           // fields emitted / elapsed
    double period_p50_s = 0.0, period_p99_s = 0.0;       // between emitted frames
    double frameTime_p50_s = 0.0, frameTime_p99_s = 0.0;  // render start → camera done
    double peakRss_MiB = 0.0;
    bool allocationsCounted = false;
    std::int64_t steadyAllocations = 0;  // operator new calls in (frames − warmFrames) ticks
    std::int64_t steadyFields = 0;
};

EndToEndResult runEndToEnd(const EndToEndRequest& req);

// The result as a JSON object (name, what, and the figures above).
std::string endToEndJson(const EndToEndRequest& req, const EndToEndResult& r);

}  // namespace nvs::rt::bench
