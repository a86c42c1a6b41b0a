#pragma once
// A run whose frames the caller pulls, one at a time, instead of a device or file taking them:
// the GStreamer source (rt/gst) and the Python module (python/) are built on it.
//
//   Session s(opts);          setup (throws SetupError, as `nvstim run` would stop)
//   while (s.next(frame)) …    blocks for the next emitted frame; false at the end of the run
//   s.stop();                  any thread: ends the run early (next() then drains and ends)
//   s.finish()                 joins the run; its exit status (docs/contracts.md, "Exit statuses")
//
// The run is `nvstim run`'s own (rt/run: ScenarioRun) on a thread of its own, with one more
// output: a ring of `depth` preallocated frames. Under the sim clock the run waits for the
// caller (every frame is delivered, bit for bit the frames a y4m output of the same run holds);
// under the wall clock a caller that falls behind loses frames, counted as that output's queue
// drops, as a slow device would.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include "rt/run/run.h"

namespace nvs::rt {

struct SessionOptions {
    std::string scenario;  // a scenario folder or .toml file
    ClockKind clock = ClockKind::Sim;
    std::optional<std::int64_t> frames;  // default: the scenario's duration
    std::string channel;                 // a rig's channel by name ("" for one camera)
    ScenarioOverrides overrides;         // --camera, --set
    std::optional<std::string> telemetry;
    std::vector<std::string> outputs;  // --output specs besides the pulled frames
    int depth = 4;                     // frames the ring holds (1..64)
    bool statusLines = false;          // the run's status lines on stderr
    DataDirs dirs;
};

// One pulled frame: the counts as the outputs write them and the frame's metadata.
struct PulledFrame {
    std::vector<std::uint16_t> counts;  // width × height, row-major, `bits` significant
    int width = 0, height = 0, bits = 8;
    std::int64_t index = 0;  // FrameMeta::frame
    std::int64_t tick = 0;
    double t_sample_s = 0.0;  // exposure mid-time on the run clock [s]
    double exposure_s = 0.0;
    double emit_s = 0.0;                // run-clock time of emission [s]
    std::int64_t emitMonotonic_ns = 0;  // CLOCK_MONOTONIC of emission (0 under the sim clock)
    bool repeat = false;
    std::string metaJson;  // the record the meta: output writes for this frame (one JSON object)
};

class Session {
  public:
    explicit Session(const SessionOptions& opts);
    ~Session();  // stops and joins the run
    Session(const Session&) = delete;
    Session& operator=(const Session&) = delete;

    // The format of the pulled frames.
    int width() const { return width_; }
    int height() const { return height_; }
    int bits() const { return bits_; }
    double frameRate_hz() const { return rate_hz_; }
    msg::FieldOrder fieldOrder() const { return fieldOrder_; }
    // The pixels' width over their height (rt/run pixelAspectOf: the y4m output's A tag).
    int pixelAspectNum() const { return aspectNum_; }
    int pixelAspectDen() const { return aspectDen_; }
    // The frames the run will emit (-1: until stopped).
    std::int64_t frames() const { return frames_; }
    const std::string& name() const { return name_; }

    // Blocks for the next frame; false once the run has ended and every frame was taken. The
    // caller's buffers are swapped with the ring's (no copy, no allocation after the first).
    bool next(PulledFrame& out);
    void stop();
    // Joins the run (stopping it if `stopFirst`); its exit status. Idempotent.
    int finish(bool stopFirst = false);

  private:
    class Ring;
    std::unique_ptr<Ring> ring_;
    std::atomic<bool> stop_{false};
    std::unique_ptr<ScenarioRun> run_;
    std::thread thread_;
    std::atomic<int> exitStatus_{0};
    bool joined_ = false;
    int width_ = 0, height_ = 0, bits_ = 8;
    double rate_hz_ = 0.0;
    msg::FieldOrder fieldOrder_ = msg::FieldOrder::Progressive;
    int aspectNum_ = 1, aspectDen_ = 1;
    std::int64_t frames_ = -1;
    std::string name_;
};

}  // namespace nvs::rt
