#pragma once
// `nvstim run` assembled from its parts (docs/design.md §7): the scenario, one platform source
// (telemetry or the scenario's held pose), the synthetic stages, the sinks named by --output,
// the frame loop, the live status line and the final statistics.

#include <atomic>
#include <cstdio>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "rt/compose/scenario.h"
#include "rt/loop/frame_loop.h"
#include "rt/loop/stages.h"
#include "sim/core/paths.h"

namespace nvs::drivers {
struct PixelAspect;
}

namespace nvs::rt {

// The pixels' aspect, width over height, of a scenario's frames: the camera's cells as the
// renderer sees them (the preset's pitch; another image size keeps the sensor's field of view),
// as the nearest ratio of integers up to 10⁴; 1:1 for a test pattern. The y4m output's A tag,
// the GStreamer source's pixel-aspect-ratio.
drivers::PixelAspect pixelAspectOf(const Scenario& sc);

struct RunRequest {
    std::string scenario;
    std::vector<std::string> outputs;
    ClockKind clock = ClockKind::Wall;
    std::optional<std::int64_t> frames;
    std::optional<std::string> telemetry;
    std::optional<std::string> statsPath;
    DataDirs dirs;  // shipped data and caches (rt/cli/data_dirs.h resolves them)
    // Overrides of the scenario's [runtime] (nvstim run --primary-visibility, --render-threads).
    std::optional<render::PrimaryVisibility> primaryVisibility;
    std::optional<int> renderThreads;  // 1..16
    std::optional<int> cameraThreads;  // 1..16
    // --camera and --set (a scenario with one [camera]).
    ScenarioOverrides overrides;
    // Outputs made by the caller rather than by --output (the GStreamer source, the Python
    // module: rt/session): each is given the frames of its channel ("" without a rig) and is
    // closed, not destroyed, by the run.
    struct CallerSink {
        std::string channel;
        FrameSink* sink = nullptr;
    };
    std::vector<CallerSink> callerSinks;
    // The flag that stops the run (null: the process's, set by SIGINT and SIGTERM, which the
    // run then installs handlers for; a library caller gives its own and no handler is set).
    std::atomic<bool>* stop = nullptr;
};

// A parsed "scheme:target?key=value&key=value" (--output and --telemetry).
struct Spec {
    std::string scheme;
    std::string target;
    std::vector<std::pair<std::string, std::string>> params;
    // Takes a parameter (marks it used); unknown leftovers are reported by finish().
    std::optional<std::string> take(const std::string& key);
    void finish(const std::string& what) const;
};
Spec parseSpec(const std::string& text, const std::string& what);

// Output spec → sink (throws SetupError naming the spec). Known schemes: y4m, pgm, png, exr,
// meta (files), v4l2 (drivers/v4l2), gpio (drivers/gpio).
// `frames` is the run's length when known (≤ 0 otherwise; the contact sheet needs it or every=N).
std::unique_ptr<FrameSink> makeSink(const std::string& spec, const Scenario& sc,
                                    std::int64_t frames);
// Telemetry spec → platform source; none → the scenario's held pose.
// `stop`: the flag a blocking source watches (null: stopRequested()).
std::unique_ptr<PlatformSource> makePlatformSource(const std::optional<std::string>& spec,
                                                   const Scenario& sc, ClockKind clock,
                                                   const DataDirs& dirs,
                                                   std::atomic<bool>* stop = nullptr);

// Statistics as one JSON object; `interrupted`: stopped by SIGINT/SIGTERM.
std::string statsJson(const FrameLoop& loop, const PlatformSource& platform,
                      const std::vector<std::unique_ptr<FrameSink>>& sinks, bool interrupted);

// What runScenario returns (docs/contracts.md, "Exit statuses"): 0, kRunFailed, or the bits
// kRunOutputFailed and kRunInterrupted (4, 8, 12).
inline constexpr int kRunFailed = 1;        // stopped by a failure (every output failed, ...)
inline constexpr int kRunOutputFailed = 4;  // at least one output failed; the run went on
inline constexpr int kRunInterrupted = 8;   // stopped by SIGINT or SIGTERM (cleanly)

// Runs to the end (frames, duration, SIGINT/SIGTERM or a fatal error). Live status lines go
// to `status` at most once a second.
int runScenario(const RunRequest& req, std::FILE* status);

// The same in two steps, for a caller that must see setup errors before the frames start
// (rt/session): the constructor sets everything up (throws SetupError); execute() runs to the
// end and returns what runScenario returns. `status` may be null (no lines).
class ScenarioRun {
  public:
    ScenarioRun(const RunRequest& req, std::FILE* status);
    ~ScenarioRun();
    ScenarioRun(const ScenarioRun&) = delete;
    ScenarioRun& operator=(const ScenarioRun&) = delete;
    // The scenario as run (a rig's channel i: channelScenario(scenario(), i)).
    const Scenario& scenario() const;
    int execute();

  private:
    struct Impl;
    std::unique_ptr<Impl> impl_;
};

// Text as a JSON string body (quotes and control characters escaped): the stats JSON's, and
// `nvstim bench`'s.
std::string jsonEscape(const std::string& text);

// The stop flag SIGINT and SIGTERM set.
std::atomic<bool>& stopRequested();
void installStopSignals();

}  // namespace nvs::rt
