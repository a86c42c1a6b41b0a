#pragma once
// Every thread nvstim runs, in one table (docs/style.md §6). Priorities are SCHED_FIFO priorities
// used when real-time scheduling is asked for and permitted (0: normal scheduling); cpu −1: any.
// The output thread outranks the render thread: a late render must never delay an emission.

#include <string>

namespace nvs::rt {

struct ThreadSpec {
    const char* name;  // pthread name (15 characters at most)
    const char* role;
    int fifoPriority;
    int cpu;
};

enum ThreadId : int {
    kThreadMain = 0,
    kThreadRender = 1,
    kThreadOutput = 2,
    kThreadGpio = 3,
    kThreadCamera = 4,
    kThreadSink = 5,
    kThreadRenderWorker = 6,
    kThreadCameraWorker = 7,
    kThreadCount = 8
};

inline constexpr ThreadSpec kThreadTable[kThreadCount] = {
    {"nvs-main", "setup, signals, live status once a second, shutdown and statistics", 0, -1},
    {"nvs-render",
     "frame k+2 (trigger clock: after its edge): poll telemetry, pose at each exposure's "
     "mid-time, render stage per frame or field",
     70, 0},
    {"nvs-output",
     "frame k: sleep to its absolute deadline (trigger clock: until ready), emit to every sink, "
     "statistics",
     80, 1},
    {"nvs-gpio",
     "gpio: output only: gate pulse per exposure, raised at the exposure start on the loop's "
     "timeline, lowered gate_s later",
     85, 1},
    {"nvs-camera",
     "frame k+1: camera stage per frame or field (state carried in order), weave, schedule "
     "the exposures",
     75, 1},
    {"nvs-sink",
     "one per output (not gpio:): takes frames from its bounded queue and writes them, so a "
     "stalled or dead consumer holds up only itself",
     78, -1},
    {"nvs-render-w",
     "render_threads − 1 of them: rows of the render thread's frame or field, handed out in "
     "chunks (RowPool); the camera thread outranks them on its core",
     70, -1},
    {"nvs-camera-w",
     "camera_threads − 1 of them: rows of the camera chain's passes, handed out in chunks "
     "(RowPool), at the camera thread's priority",
     75, -1},
};

// Names the calling thread after its table entry and, when `realtime`, applies its priority
// and CPU. A refusal is reported once in `message` and is not an error.
int applyThreadSpec(ThreadId id, bool realtime, std::string& message);

}  // namespace nvs::rt
