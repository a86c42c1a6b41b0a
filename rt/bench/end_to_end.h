#pragma once
// End-to-end figures of `nvstim bench`: a scenario run through the real frame loop under the
// sim clock, as `nvstim run SCENARIO --clock sim --frames N --output y4m:/dev/null --output meta:-`
// runs it (rt/run's runScenario), in a child process of its own so that its peak RSS
// (getrusage ru_maxrss of the child, from wait4) is that run's alone.
//
// The run's outputs are y4m:/dev/null and meta:- (the child's stdout, a pipe to a watcher
// thread of the child, which notes when each frame's line arrives: the emission period as an
// output sees it; the loop keeps its own period statistics under the wall clock only).
//
// Steady-state allocations: the watcher reads the operator new count (rt/bench/alloc_count.h)
// when frame warmFrames's line arrives and again at frame frames − 2's; in between every thread
// of the run (render, camera, output, sinks) worked on steady frames.
//
// Must be called while the calling process has a single thread (fork).

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>

#include "sim/core/paths.h"
#include "sim/render/renderer.h"

namespace nvs::rt::bench {

struct EndToEndRequest {
    std::string name;
    std::string what;
    std::filesystem::path scenario;
    DataDirs dirs;
    int warmFrames = 20;  // frames before the steady state (period, allocations)
    int frames = 60;      // frames in the run
    double targetFields_per_s = 59.94;
    // Overrides of the scenario's [runtime] (RunRequest's).
    std::optional<render::PrimaryVisibility> primaryVisibility;
    std::optional<int> renderThreads;
    std::optional<int> cameraThreads;
};

struct EndToEndResult {
    bool ok = false;
    std::string error;       // why not ok
    int fieldsPerFrame = 1;  // 2: interlaced
    std::int64_t frames = 0;
    double elapsed_s = 0.0;
    // Steady state (after warmFrames): fields per second and the interval between consecutive
    // frames, as the metadata output receives them (its line for each frame, timed by the
    // parent: the loop's own period statistics are kept under the wall clock only).
    double fields_per_s = 0.0;
    double period_p50_s = 0.0, period_p99_s = 0.0;
    double fieldsPerSecondWholeRun = 0.0;  // frames emitted · fields / the run's elapsed_s
    double frameTime_p50_s = 0.0, frameTime_p99_s = 0.0;  // render start → camera done
    double overhead_p50_s = 0.0, overhead_p99_s = 0.0;    // the loop's own work per frame
    double peakRss_MiB = 0.0;
    bool allocationsCounted = false;
    std::int64_t steadyAllocations = 0;  // operator new calls in the steady window
    std::int64_t steadyFields = 0;
    // CPU time of all the run's threads per field in the steady window (getrusage): what a
    // field costs whatever else the machine runs; on n idle cores at most n / this fields/s.
    double cpuPerField_s = 0.0;
};

EndToEndResult runEndToEnd(const EndToEndRequest& req);

// The result as a JSON object (name, what, and the figures above).
std::string endToEndJson(const EndToEndRequest& req, const EndToEndResult& r);

}  // namespace nvs::rt::bench
