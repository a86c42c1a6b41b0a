#include "rt/run/run.h"

#include <signal.h>

#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <fstream>
#include <thread>

#include "drivers/sinks/sinks.h"
#include "rt/camera_stage/bolometer_stage.h"
#include "rt/camera_stage/camera_stage.h"
#include "rt/clock/threads.h"
#include "rt/render_stage/render_stage.h"
#include "rt/render_stage/row_pool.h"
#include "rt/run/telemetry_factory.h"
#include "rt/run/timeline.h"
#include "rt/synth/synth.h"
#include "sim/core/error.h"
#include "sim/sensor/mtf.h"

namespace nvs::rt {

std::optional<std::string> Spec::take(const std::string& key) {
    for (auto it = params.begin(); it != params.end(); ++it) {
        if (it->first == key) {
            std::string v = it->second;
            params.erase(it);
            return v;
        }
    }
    return std::nullopt;
}

void Spec::finish(const std::string& what) const {
    if (!params.empty()) {
        throw SetupError(what + ": unknown parameter '" + params.front().first + "'");
    }
}

Spec parseSpec(const std::string& text, const std::string& what) {
    Spec s;
    const auto colon = text.find(':');
    if (colon == std::string::npos || colon == 0) {
        throw SetupError(what + " '" + text + "': expected SCHEME:TARGET");
    }
    s.scheme = text.substr(0, colon);
    std::string rest = text.substr(colon + 1);
    const auto q = rest.find('?');
    s.target = rest.substr(0, q);
    if (q != std::string::npos) {
        std::string query = rest.substr(q + 1);
        std::size_t pos = 0;
        while (pos <= query.size()) {
            const auto amp = query.find('&', pos);
            const std::string kv = query.substr(pos, amp == std::string::npos ? amp : amp - pos);
            const auto eq = kv.find('=');
            if (kv.empty() || eq == std::string::npos || eq == 0) {
                throw SetupError(what + " '" + text + "': parameter '" + kv + "' is not KEY=VALUE");
            }
            s.params.emplace_back(kv.substr(0, eq), kv.substr(eq + 1));
            if (amp == std::string::npos) break;
            pos = amp + 1;
        }
    }
    if (s.target.empty()) throw SetupError(what + " '" + text + "': empty target");
    return s;
}

// The pixels' aspect (width over height) as the y4m header gives it: the camera's cells as the
// renderer sees them (rt/compose/scene_setup.cpp: the preset's pitch, another image size keeping
// the sensor's field of view), as the nearest ratio of integers up to 10⁴ (continued fractions).
drivers::PixelAspect pixelAspectOf(const Scenario& sc) {
    if (!sc.rendered || !sc.camera.enabled) return {};
    double x = 0.0;
    if (sc.camera.thermal) {
        const auto& tp = *sc.camera.thermalParams;
        x = (static_cast<double>(tp.width) / sc.width) /
            (static_cast<double>(tp.height) / sc.height);
    } else {
        const sensor::CameraParams& cp = sc.camera.params;
        x = sensor::cathodePitchX_mm(cp) / sensor::cathodePitchY_mm(cp) *
            (static_cast<double>(cp.width) / sc.width) /
            (static_cast<double>(cp.height) / sc.height);
    }
    if (!(x > 0.0) || !std::isfinite(x)) return {};
    long h0 = 0, h1 = 1, k0 = 1, k1 = 0;  // convergents h/k
    double r = x;
    for (int i = 0; i < 20; ++i) {
        const long a = static_cast<long>(std::floor(r));
        const long h2 = a * h1 + h0, k2 = a * k1 + k0;
        if (k2 > 10000 || h2 > 10000) break;
        h0 = h1, h1 = h2, k0 = k1, k1 = k2;
        if (std::fabs(static_cast<double>(h1) / static_cast<double>(k1) - x) < 1e-9 * x) break;
        r = 1.0 / (r - static_cast<double>(a));
        if (!std::isfinite(r)) break;
    }
    return {static_cast<int>(h1), static_cast<int>(k1)};
}

std::unique_ptr<FrameSink> makeSink(const std::string& text, const Scenario& sc,
                                    std::int64_t frames) {
    Spec s = parseSpec(text, "--output");
    const std::string what = "--output " + text;
    std::unique_ptr<FrameSink> sink;
    if (s.scheme == "y4m") {
        sink = std::make_unique<drivers::Y4mSink>(s.target, sc.width, sc.height, sc.bits, sc.rate,
                                                  sc.fieldOrder(), pixelAspectOf(sc));
    } else if (s.scheme == "pgm") {
        sink = std::make_unique<drivers::PgmSequenceSink>(s.target, sc.width, sc.height, sc.bits);
    } else if (s.scheme == "png") {
        sink = std::make_unique<drivers::PngSequenceSink>(s.target, sc.width, sc.height, sc.bits);
    } else if (s.scheme == "exr") {
        sink = std::make_unique<drivers::ExrSequenceSink>(s.target, sc.width, sc.height);
    } else if (s.scheme == "meta") {
        sink = std::make_unique<drivers::MetaJsonlSink>(s.target);
    } else if (s.scheme == "contact") {
        const auto num = [&](const char* key, int def) {
            const auto v = s.take(key);
            if (!v) return def;
            char* end = nullptr;
            errno = 0;
            const long n = std::strtol(v->c_str(), &end, 10);
            if (end == v->c_str() || *end != '\0' || errno == ERANGE || n < 0 || n > 1'000'000)
                throw SetupError(what + ": " + key + " must be an integer in [0, 1000000]");
            return static_cast<int>(n);
        };
        const int cols = num("cols", 4), rows = num("rows", 3), shrink = num("shrink", 2);
        const int every = num("every", 0);
        sink = std::make_unique<drivers::ContactSheetSink>(s.target, sc.width, sc.height, sc.bits,
                                                           cols, rows, shrink, frames, every);
    } else {
        sink = makeDeviceSink(s, sc, what);
        if (!sink) {
            throw SetupError(what + ": unknown output scheme '" + s.scheme +
                             "' (known: v4l2, y4m, pgm, png, exr, meta, contact, gpio)");
        }
    }
    s.finish(what);
    return sink;
}

std::unique_ptr<PlatformSource> makePlatformSource(const std::optional<std::string>& text,
                                                   const Scenario& sc, ClockKind clock,
                                                   const DataDirs& dirs, std::atomic<bool>* stop) {
    if (!text) return std::make_unique<HeldPlatform>(sc.platform);
    Spec s = parseSpec(*text, "--telemetry");
    auto src = makeTelemetrySource(s, sc, clock, "--telemetry " + *text, dirs.config,
                                   stop != nullptr ? stop : &stopRequested());
    s.finish("--telemetry " + *text);
    return src;
}

namespace {

std::atomic<bool> gStop{false};

extern "C" void onStopSignal(int /*sig*/) {
    gStop.store(true, std::memory_order_relaxed);
}

}  // namespace

std::atomic<bool>& stopRequested() {
    return gStop;
}

void installStopSignals() {
    struct sigaction sa {};
    sa.sa_handler = onStopSignal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = 0;
    sigaction(SIGINT, &sa, nullptr);
    sigaction(SIGTERM, &sa, nullptr);
    // A vanished pipe reader is an EPIPE write error, counted by its sink, not a kill.
    signal(SIGPIPE, SIG_IGN);
    // A file-size limit is a write error (EFBIG) on that sink, like a full disk.
    signal(SIGXFSZ, SIG_IGN);
}

std::string statsJson(const FrameLoop& loop, const PlatformSource& platform,
                      const std::vector<std::unique_ptr<FrameSink>>& sinks, bool interrupted) {
    const RunStats& st = loop.stats();
    const RunCounters& c = st.counters;
    const LoopConfig& cfg = loop.config();
    std::string j = "{";
    char buf[512];
    std::snprintf(buf, sizeof buf,
                  "\"clock\":\"%s\",\"frame_rate_hz\":%.6f,\"elapsed_s\":%.6f,\"ticks\":%lld,"
                  "\"frames_rendered\":%lld,\"frames_emitted\":%lld,\"deadline_misses\":%lld,"
                  "\"repeats\":%lld,\"dropped_frames\":%lld,\"skipped_ticks\":%lld,"
                  "\"late_frames\":%lld,\"skipped_renders\":%lld,\"sink_errors\":%lld,"
                  "\"sink_queue_drops\":%lld,\"outputs_failed\":%lld,\"stale_frames\":%lld,",
                  cfg.clock == ClockKind::Wall
                      ? "wall"
                      : (cfg.clock == ClockKind::Trigger ? "trigger" : "sim"),
                  cfg.rate.hz(), st.elapsed_s, static_cast<long long>(c.ticks),
                  static_cast<long long>(c.framesRendered), static_cast<long long>(c.framesEmitted),
                  static_cast<long long>(c.deadlineMisses), static_cast<long long>(c.repeats),
                  static_cast<long long>(c.droppedFrames), static_cast<long long>(c.skippedTicks),
                  static_cast<long long>(c.lateFrames), static_cast<long long>(c.skippedRenders),
                  static_cast<long long>(c.sinkErrors), static_cast<long long>(c.sinkQueueDrops),
                  static_cast<long long>(c.outputsFailed), static_cast<long long>(c.staleFrames));
    j += buf;
    j += "\"period\":" + st.period.json() + ",\"wake_late\":" + st.wakeLate.json() +
         ",\"frame_time\":" + st.frameTime.json() + ",\"overhead\":" + st.overhead.json() +
         ",\"sink_time\":" + st.sinkTime.json() + ",\"latency\":" + st.latency.json() +
         ",\"telemetry_latency\":" + st.latency.json() +
         ",\"render_latency\":" + st.renderLatency.json();
    // The run clock's origin (t = 0 of t_sample_s) on CLOCK_MONOTONIC, the clock of GPIO line
    // events: a frame's exposure window on that clock is origin + t_sample_s ± exposure/2
    // (tests/hil checks the gate line and the trigger's edges with it). 0 under the sim clock.
    // Start-up: the loop's threads made before the origin (loop_start_s), and the first frame
    // finished, when (run clock; negative: before tick 0; 0 under the sim clock).
    std::snprintf(
        buf, sizeof buf,
        ",\"clock_origin_ns\":%lld,\"loop_start_s\":%.6f,\"first_frame\":%lld,"
        "\"first_frame_made_s\":%.6f",
        static_cast<long long>(cfg.clock == ClockKind::Sim ? 0 : loop.wallClock().start_ns()),
        st.loopStart_s, static_cast<long long>(st.firstFrame),
        cfg.clock == ClockKind::Sim ? 0.0 : st.firstFrameMade_s);
    j += buf;
    j += std::string(",\"scan\":\"") +
         (cfg.scan == ScanKind::Interlaced ? "interlaced" : "progressive") + "\"";
    if (cfg.clock == ClockKind::Trigger && cfg.trigger != nullptr) {
        const TriggerStats& t = loop.triggerStats();
        std::snprintf(buf, sizeof buf,
                      ",\"trigger\":{\"edges\":%lld,\"frames\":%lld,\"missing\":%lld,"
                      "\"extra\":%lld,\"overruns\":%lld,\"stalls\":%lld,\"errors\":%lld,",
                      static_cast<long long>(t.edges), static_cast<long long>(t.frames),
                      static_cast<long long>(t.missing), static_cast<long long>(t.extra),
                      static_cast<long long>(t.overruns), static_cast<long long>(t.stalls),
                      static_cast<long long>(t.errors));
        j += buf;
        j += "\"interval\":" + t.interval.json() + ",\"latency\":" + t.latency.json() +
             ",\"input\":\"" + jsonEscape(cfg.trigger->status()) + "\"}";
    }
    j += ",\"telemetry\":\"" + jsonEscape(platform.status()) + "\",\"outputs\":[";
    for (std::size_t i = 0; i < sinks.size(); ++i) {
        j += (i > 0 ? ",\"" : "\"") + jsonEscape(sinks[i]->status()) + "\"";
    }
    // Each output's queue: what it was handed, wrote, lost to a full queue, and how long a
    // frame took from hand-off to written.
    j += "],\"sinks\":[";
    for (std::size_t i = 0; i < loop.channelCount(); ++i) {
        const SinkChannel& ch = loop.channel(i);
        const SinkChannelCounters sc = ch.counters();
        std::snprintf(buf, sizeof buf,
                      "%s{\"offered\":%lld,\"written\":%lld,\"queue_drops\":%lld,"
                      "\"errors\":%lld,\"failed\":%s,\"write_latency\":",
                      i > 0 ? "," : "", static_cast<long long>(sc.offered),
                      static_cast<long long>(sc.written), static_cast<long long>(sc.queueDrops),
                      static_cast<long long>(sc.errors), sc.failed ? "true" : "false");
        j += std::string(buf) + ch.writeLatency().json() + ",\"name\":\"" +
             jsonEscape(ch.sink().name()) + "\"}";
    }
    j += "],\"interrupted\":" + std::string(interrupted ? "true" : "false");
    j += ",\"failure\":\"" + jsonEscape(loop.failure()) + "\"}";
    return j;
}

namespace {

void printSummary(std::FILE* status, const std::string& name, const FrameLoop& loop,
                  const PlatformSource& platform,
                  const std::vector<std::unique_ptr<FrameSink>>& sinks) {
    const RunCounters& c = loop.stats().counters;
    const RunStats& st = loop.stats();
    std::fprintf(status,
                 "nvstim run: %s: %lld frames emitted in %.3f s; misses %lld (repeated %lld, "
                 "nothing sent %lld, skipped ticks %lld), late frames %lld, skipped renders "
                 "%lld, sink errors %lld, queue drops %lld; period p50 %.3f p99 %.3f max %.3f "
                 "ms; render to emission p50 %.3f p99 %.3f max %.3f ms\n",
                 name.c_str(), static_cast<long long>(c.framesEmitted), st.elapsed_s,
                 static_cast<long long>(c.deadlineMisses), static_cast<long long>(c.repeats),
                 static_cast<long long>(c.droppedFrames), static_cast<long long>(c.skippedTicks),
                 static_cast<long long>(c.lateFrames), static_cast<long long>(c.skippedRenders),
                 static_cast<long long>(c.sinkErrors), static_cast<long long>(c.sinkQueueDrops),
                 st.period.quantile_s(0.5) * 1e3, st.period.quantile_s(0.99) * 1e3,
                 st.period.max_s() * 1e3, st.renderLatency.quantile_s(0.5) * 1e3,
                 st.renderLatency.quantile_s(0.99) * 1e3, st.renderLatency.max_s() * 1e3);
    if (st.latency.count() > 0) {
        std::fprintf(status, "nvstim run: telemetry to emission p50 %.3f p99 %.3f max %.3f ms\n",
                     st.latency.quantile_s(0.5) * 1e3, st.latency.quantile_s(0.99) * 1e3,
                     st.latency.max_s() * 1e3);
    }
    std::fprintf(status, "nvstim run: telemetry: %s\n", platform.status().c_str());
    for (std::size_t i = 0; i < sinks.size(); ++i) {
        const SinkChannelCounters q = loop.channel(i).counters();
        std::fprintf(status, "nvstim run: output %s; queue drops %lld\n",
                     sinks[i]->status().c_str(), static_cast<long long>(q.queueDrops));
    }
    if (!loop.failure().empty()) std::fprintf(status, "nvstim run: %s\n", loop.failure().c_str());
}

}  // namespace

namespace {

// The loop's configuration from the scenario and the command line (setup errors thrown).
LoopConfig loopConfigFor(const Scenario& sc, const RunRequest& req) {
    LoopConfig cfg;
    cfg.rate = sc.rate;
    cfg.clock = req.clock;
    cfg.latePolicy = sc.latePolicy;
    cfg.sinkErrorPolicy = sc.sinkErrors;
    cfg.exposure_s = sc.exposure_s;
    cfg.width = sc.width;
    cfg.height = sc.height;
    cfg.realtime = sc.realtime;
    cfg.scan = sc.scan;
    cfg.topFieldFirst = sc.fieldOrder() != msg::FieldOrder::BottomFirst;
    cfg.fieldRowsOnly = sc.fieldRowsOwn && sc.scan == ScanKind::Interlaced;
    cfg.triggerTimeout_s = sc.triggerTimeout_s;
    if (req.frames) {
        cfg.frames = *req.frames;
    } else if (sc.duration_s) {
        cfg.frames = static_cast<std::int64_t>(std::ceil(*sc.duration_s * sc.rate.hz() - 1e-9));
    } else if (req.clock == ClockKind::Sim) {
        throw SetupError("--clock sim needs --frames N or [scenario] duration_s");
    }
    return cfg;
}

// One live status line from the loop's atomic counters; returns the frames emitted so far.
std::int64_t printLiveStatus(std::FILE* status, const FrameLoop& loop, double dt_s,
                             std::int64_t lastEmitted, const std::string& label) {
    const LiveCounters& l = loop.live();
    const std::int64_t e = l.emitted.load();
    const std::int64_t lat = l.lastLatency_ns.load();
    char trig[128] = "";
    if (loop.config().clock == ClockKind::Trigger) {
        std::snprintf(trig, sizeof trig, "  trigger missing %lld extra %lld%s",
                      static_cast<long long>(l.triggerMissing.load()),
                      static_cast<long long>(l.triggerExtra.load()),
                      l.triggerStalled.load() ? "  TRIGGER STALLED" : "");
    }
    // The run's length where it is known: frame N/TOTAL, and the time left at the last
    // second's rate (ticks that missed count as done: they pass like the others).
    const double fps = static_cast<double>(e - lastEmitted) / dt_s;
    char total[32] = "", left[32] = "";
    if (const std::int64_t n = loop.config().frames; n > 0) {
        const std::int64_t done = e + l.misses.load();
        std::snprintf(total, sizeof total, "/%lld", static_cast<long long>(n));
        if (fps > 0.0) {
            std::snprintf(left, sizeof left, "  %.0f s left",
                          static_cast<double>(done < n ? n - done : 0) / fps);
        }
    }
    // A miss is repeated or sends nothing; late and skipped say what became of the frames that
    // missed; queue drops are frames a stalled output could not take.
    std::fprintf(status,
                 "nvstim run: %s%sframe %lld%s  %.2f fps%s  misses %lld (repeated %lld, nothing "
                 "sent %lld)  late %lld  skipped %lld  sink errors %lld  queue drops %lld"
                 "%s  latency %s%.2f ms%s%s\n",
                 label.c_str(), label.empty() ? "" : ": ", static_cast<long long>(e), total, fps,
                 left, static_cast<long long>(l.misses.load()),
                 static_cast<long long>(l.repeats.load()), static_cast<long long>(l.dropped.load()),
                 static_cast<long long>(l.late.load()), static_cast<long long>(l.skipped.load()),
                 static_cast<long long>(l.sinkErrors.load()),
                 static_cast<long long>(l.queueDrops.load()),
                 l.outputsFailed.load() > 0 ? "  OUTPUT FAILED" : "", lat < 0 ? "n/a " : "",
                 lat < 0 ? 0.0 : static_cast<double>(lat) * 1e-6,
                 l.stale.load() ? "  TELEMETRY STALE" : "", trig);
    std::fflush(status);
    return e;
}

}  // namespace

namespace {

// One camera's pipeline (a rig has one per channel): its outputs, stages, platform source and
// frame loop, built in this order and torn down in the reverse.
struct Pipeline {
    Scenario sc;
    std::string label;  // the channel's name ("" without a rig)
    std::vector<std::unique_ptr<FrameSink>> sinks;
    std::vector<FrameSink*> callerSinks;  // RunRequest::callerSinks of this channel
    std::unique_ptr<SceneRenderStage> sceneStage;
    std::unique_ptr<TestPatternRender> testPattern;
    std::unique_ptr<PlatformSource> platform;
    GammaTableCache gammaTables;          // the MCP's Gamma tables, built here at setup
    std::unique_ptr<RowPool> cameraPool;  // [runtime] camera_threads > 1; outlives the stage
    std::unique_ptr<CameraStage> camera;
    std::unique_ptr<TriggerSource> trigger;
    std::vector<std::string> notes;
    std::unique_ptr<FrameLoop> loop;
    std::string prefix() const { return label.empty() ? "" : label + ": "; }
};

// The camera stage of a pipeline: the bolometer, the IICCD chain or the linear test camera.
void makeCamera(Pipeline& p, const RunRequest& req, std::FILE* status) {
    const Scenario& sc = p.sc;
    if (sc.camera.thermal) {
        const ThermalScene& th = *p.sceneStage->thermal();
        std::fprintf(status,
                     "nvstim run: %sthermal: %zu surface classes, heat balance %s (%zu kB of "
                     "state), weather %s\n",
                     p.prefix().c_str(), th.surfaces().size(),
                     th.report().fromCache ? "from the cache" : "solved",
                     th.report().stateBytes / 1024, th.weather().file().c_str());
        // The camera powered up before the run, its start-up shutter done facing the night.
        const double start = th.groundRadianceAt(sc.utcStart_unix_s);
        p.camera = std::make_unique<BolometerCameraStage>(*sc.camera.thermalParams, sc.bits,
                                                          sc.camera.seed, start, req.dirs.config);
    } else if (sc.camera.enabled) {
        auto iiccd = std::make_unique<IiccdCameraStage>(
            sc.camera.params, sc.camera.spectrum, sc.camera.seed,
            sc.camera.controlsFromPlatform ? IiccdCameraStage::Controls::Platform
                                           : IiccdCameraStage::Controls::Preset,
            req.dirs.config, p.gammaTables);
        if (sc.cameraThreads > 1) {
            p.cameraPool =
                std::make_unique<RowPool>(sc.cameraThreads, sc.realtime, kThreadCameraWorker);
            iiccd->setExecutor(p.cameraPool.get());
        }
        p.camera = std::move(iiccd);
    } else {
        p.camera = std::make_unique<LinearCamera>(sc.testPattern.fullScale_W_m2_sr, sc.bits);
    }
}

// A pipeline for `p.sc` with these outputs (setup errors thrown).
void buildPipeline(Pipeline& p, const RunRequest& req, const std::vector<std::string>& outputs,
                   std::FILE* status) {
    Scenario& sc = p.sc;
    LoopConfig cfg = loopConfigFor(sc, req);
    for (const std::string& o : outputs)
        p.sinks.push_back(makeSink(o, sc, cfg.frames));
    // Frames: the scene renderer (photoelectron radiance, which the camera takes as is) or the
    // test pattern (band radiance).
    p.testPattern = std::make_unique<TestPatternRender>(sc.testPattern.radianceMax_W_m2_sr,
                                                        sc.testPattern.targetSpeed_px_s);
    RenderStage* render = p.testPattern.get();
    if (sc.rendered) {
        p.sceneStage = SceneRenderStage::create(sc, req.dirs);
        render = p.sceneStage.get();
        if (sc.primaryVisibility != render::PrimaryVisibility::kEmbree) {
            std::fprintf(status, "nvstim run: %s%s\n", p.prefix().c_str(),
                         p.sceneStage->primaryVisibilityNote().c_str());
        }
        sc.platform.lampMask = p.sceneStage->initialLampMask();
        sc.camera.spectrum = "pe";
    }
    p.platform = makePlatformSource(req.telemetry ? req.telemetry : sc.telemetry, sc, req.clock,
                                    req.dirs, req.stop);
    if (!sc.events.empty()) {
        SceneRenderStage* stage = p.sceneStage.get();
        p.platform = std::make_unique<TimelineSource>(
            std::move(p.platform), resolveTimeline(sc, [stage](const std::string& name) {
                return stage ? stage->scenario().scene().lampIndex(name) : -1;
            }));
    }
    makeCamera(p, req, status);
    // External trigger: the frames follow its edges on the wall clock. The sim clock keeps
    // its nominal cadence, so a triggered scenario still replays bit for bit.
    if (sc.trigger && req.clock == ClockKind::Wall) {
        p.trigger = makeTrigger(*sc.trigger, sc.file + ": [runtime] trigger");
        cfg.clock = ClockKind::Trigger;
        cfg.trigger = p.trigger.get();
    } else if (sc.trigger) {
        p.notes.push_back("[runtime] trigger is not used with --clock sim (nominal " +
                          std::to_string(sc.rate.hz()) + " Hz)");
    }
    // A live bus under the sim clock: the frames step with the telemetry's own time. The line
    // says the bus is open and the loop waits, so a sender may start (tests/hil waits for it).
    const std::optional<std::string>& tel = req.telemetry ? req.telemetry : sc.telemetry;
    if (req.clock == ClockKind::Sim && tel && tel->rfind("can:", 0) == 0) {
        p.notes.push_back("lockstep: frames follow the time signal of " + *tel);
    }
    if (sc.channelIndex >= 0 && !sc.channels.empty()) {
        const ChannelSpec& ch = sc.channels[static_cast<std::size_t>(sc.channelIndex)];
        cfg.skew_s = ch.faults.skew_s;
        cfg.stampJitter_s = ch.faults.stampJitter_s;
        cfg.dropProbability = ch.faults.dropProbability;
        cfg.faultSeed = sc.seed * 131 + static_cast<std::uint64_t>(sc.channelIndex) + 1;
    }
    std::vector<FrameSink*> raw;
    for (auto& s : p.sinks)
        raw.push_back(s.get());
    for (FrameSink* s : p.callerSinks)
        raw.push_back(s);
    p.loop = std::make_unique<FrameLoop>(cfg, *p.platform, *render, *p.camera, raw);
}

// The command line's outputs, per channel: a rig's name theirs with ?channel=NAME.
std::vector<std::vector<std::string>> routeOutputs(const std::vector<std::string>& outputs,
                                                   const Scenario& sc) {
    const std::size_t n = sc.channels.empty() ? 1 : sc.channels.size();
    std::vector<std::vector<std::string>> routed(n);
    std::string names;
    for (const ChannelSpec& ch : sc.channels)
        names += (names.empty() ? "" : ", ") + ch.name;
    for (const std::string& o : outputs) {
        Spec s = parseSpec(o, "--output");
        const std::optional<std::string> ch = s.take("channel");
        if (sc.channels.empty()) {
            if (ch) throw SetupError("--output " + o + ": channel= needs a rig ([[channel]])");
            routed[0].push_back(o);
            continue;
        }
        if (!ch) {
            throw SetupError("--output " + o +
                             ": the scenario is a rig; name the channel with "
                             "?channel=NAME (" +
                             names + ")");
        }
        std::size_t i = 0;
        while (i < sc.channels.size() && sc.channels[i].name != *ch)
            ++i;
        if (i == sc.channels.size()) {
            throw SetupError("--output " + o + ": no channel '" + *ch + "' (" + names + ")");
        }
        // The spec without its channel parameter.
        std::string rest = s.scheme + ":" + s.target;
        for (std::size_t k = 0; k < s.params.size(); ++k)
            rest += (k == 0 ? "?" : "&") + s.params[k].first + "=" + s.params[k].second;
        routed[i].push_back(rest);
    }
    return routed;
}

// The scenario with the command line's overrides of [runtime].
Scenario scenarioFor(const RunRequest& req) {
    Scenario sc = loadScenario(req.scenario, req.dirs.config, req.overrides);
    if (req.primaryVisibility) sc.primaryVisibility = *req.primaryVisibility;
    if (req.renderThreads) {
        if (*req.renderThreads < 1 || *req.renderThreads > 16) {
            throw SetupError("render threads must be in [1, 16]");
        }
        sc.renderThreads = *req.renderThreads;
    }
    if (req.cameraThreads) {
        if (*req.cameraThreads < 1 || *req.cameraThreads > 16) {
            throw SetupError("camera threads must be in [1, 16]");
        }
        sc.cameraThreads = *req.cameraThreads;
    }
    if (!sc.channels.empty()) {
        const std::optional<std::string>& tel = req.telemetry ? req.telemetry : sc.telemetry;
        if (tel && tel->rfind("serial:", 0) == 0) {
            throw SetupError(
                "a rig's channels each read the telemetry; a serial port has one "
                "reader (use can: or replay:)");
        }
        if (sc.trigger) {
            throw SetupError(sc.file +
                             ": [runtime] trigger: a rig runs on one time line; an external "
                             "trigger drives a single camera");
        }
    }
    return sc;
}

// Every pipeline of the run: one, or one per channel of a rig.
std::vector<std::unique_ptr<Pipeline>> buildPipelines(const RunRequest& req, const Scenario& sc,
                                                      std::FILE* status) {
    const auto routed = routeOutputs(req.outputs, sc);
    int toStdout = 0;
    for (const std::string& o : req.outputs)
        if (o.size() > 2 && o.compare(o.size() - 2, 2, ":-") == 0) ++toStdout;
    if (toStdout > 1) throw SetupError("--output: only one output can go to stdout");
    for (const RunRequest::CallerSink& c : req.callerSinks) {
        bool known = c.channel.empty() && sc.channels.empty();
        std::string names;
        for (const ChannelSpec& ch : sc.channels) {
            known = known || ch.name == c.channel;
            names += (names.empty() ? "" : ", ") + ch.name;
        }
        if (known) continue;
        if (sc.channels.empty())
            throw SetupError(sc.file + ": channel '" + c.channel +
                             "': the scenario has one camera");
        throw SetupError(sc.file + ": the scenario is a rig; name a channel (" + names +
                         (c.channel.empty() ? ")" : "; not '" + c.channel + "')"));
    }
    std::vector<std::unique_ptr<Pipeline>> pipes;
    for (std::size_t i = 0; i < routed.size(); ++i) {
        auto p = std::make_unique<Pipeline>();
        p->sc = channelScenario(sc, i);
        if (!sc.channels.empty()) p->label = sc.channels[i].name;
        for (const RunRequest::CallerSink& c : req.callerSinks)
            if (c.channel == p->label) p->callerSinks.push_back(c.sink);
        buildPipeline(*p, req, routed[i], status);
        pipes.push_back(std::move(p));
    }
    // A rig: every channel's pinhole, for the homographies each publishes.
    std::vector<render::PinholeCamera> pins;
    for (const auto& p : pipes)
        if (p->sceneStage) pins.push_back(p->sceneStage->scenario().renderer().camera());
    for (const auto& p : pipes) {
        if (p->sceneStage && pins.size() == pipes.size()) {
            p->sceneStage->setRigPinholes(pins.data(), static_cast<int>(pins.size()));
        }
    }
    return pipes;
}

// The stats file: a pipeline's JSON object, or a rig's {"channels":[…]} of them.
int writeStats(const RunRequest& req, const std::vector<std::unique_ptr<Pipeline>>& pipes,
               bool interrupted, std::FILE* status) {
    std::string json;
    if (pipes.size() == 1 && pipes[0]->label.empty()) {
        json = statsJson(*pipes[0]->loop, *pipes[0]->platform, pipes[0]->sinks, interrupted);
    } else {
        json = "{\"channels\":[";
        for (std::size_t i = 0; i < pipes.size(); ++i) {
            const Pipeline& p = *pipes[i];
            std::string one = statsJson(*p.loop, *p.platform, p.sinks, interrupted);
            char extra[160];
            std::snprintf(extra, sizeof extra, "{\"channel\":\"%s\",\"fault_drops\":%lld,",
                          jsonEscape(p.label).c_str(),
                          static_cast<long long>(p.loop->faultDrops()));
            json += (i > 0 ? "," : "") + std::string(extra) + one.substr(1);
        }
        json += "],\"interrupted\":" + std::string(interrupted ? "true" : "false") + "}";
    }
    json += "\n";
    drivers::AtomicFile f;
    int rc = f.open(req.statsPath->c_str());
    if (rc == 0) rc = f.write(json.data(), json.size());
    if (rc == 0) rc = f.commit(true);
    if (rc != 0) {
        std::fprintf(status, "nvstim run: --stats %s: %s\n", req.statsPath->c_str(),
                     std::strerror(-rc));
        return kRunFailed;
    }
    return 0;
}

// Starts every loop on one origin: the rig's time line (frame 0's tick of each channel, its
// skew added), far enough ahead for the slowest to make its first frame.
void startAll(const std::vector<std::unique_ptr<Pipeline>>& pipes, std::atomic<bool>& stop,
              std::FILE* status) {
    std::string mainMsg;
    applyThreadSpec(kThreadMain, false, mainMsg);
    std::int64_t lead_ns = 0;
    for (const auto& p : pipes) {
        std::vector<std::string> messages = p->notes;
        if (stop.load(std::memory_order_relaxed)) p->loop->requestStop();
        p->loop->prepare(messages);
        for (const auto& m : messages)
            std::fprintf(status, "nvstim run: %s%s\n", p->prefix().c_str(), m.c_str());
        lead_ns = std::max(lead_ns, p->loop->originLead_ns());
    }
    const std::int64_t origin_ns = monotonicNow_ns() + lead_ns;
    for (const auto& p : pipes)
        p->loop->go(pipes.size() == 1 ? 0 : origin_ns);
}

}  // namespace

struct ScenarioRun::Impl {
    RunRequest req;
    std::FILE* status = nullptr;
    std::FILE* devNull = nullptr;  // status lines when the caller wants none
    std::atomic<bool>* stop = nullptr;
    Scenario sc;
    std::vector<std::unique_ptr<Pipeline>> pipes;
    ~Impl() {
        if (devNull != nullptr) std::fclose(devNull);
    }
};

ScenarioRun::ScenarioRun(const RunRequest& req, std::FILE* status) : impl_(new Impl) {
    Impl& r = *impl_;
    r.req = req;
    r.stop = req.stop != nullptr ? req.stop : &stopRequested();
    // SIGINT and SIGTERM stop the run from the start, setup included. A shell without job
    // control starts background commands with SIGINT ignored; sigaction replaces that inherited
    // SIG_IGN on purpose: a stimulator asked to stop must stop, whoever started it. A signal
    // that arrives during setup (camera FFT plans, telemetry files) is kept and honoured as
    // soon as the loop exists. A library caller (req.stop given) keeps its own handlers.
    if (req.stop == nullptr) installStopSignals();
    if (status == nullptr) {
        r.devNull = std::fopen("/dev/null", "w");
        if (r.devNull == nullptr) throw SetupError("/dev/null: cannot open");
        status = r.devNull;
    }
    r.status = status;
    // Setup: everything that can fail fails here, before the first frame.
    r.sc = scenarioFor(req);
    r.pipes = buildPipelines(req, r.sc, status);
}

ScenarioRun::~ScenarioRun() = default;

const Scenario& ScenarioRun::scenario() const {
    return impl_->sc;
}

int runScenario(const RunRequest& req, std::FILE* status) {
    ScenarioRun run(req, status);
    return run.execute();
}

int ScenarioRun::execute() {
    const RunRequest& req = impl_->req;
    std::FILE* status = impl_->status;
    std::atomic<bool>& stop = *impl_->stop;
    const Scenario& sc = impl_->sc;
    std::vector<std::unique_ptr<Pipeline>>& pipes = impl_->pipes;
    startAll(pipes, stop, status);

    // Live status at most once a second, from the loops' atomic counters.
    auto lastPrint = std::chrono::steady_clock::now();
    std::vector<std::int64_t> lastEmitted(pipes.size(), 0);
    for (;;) {
        bool finished = true;
        for (const auto& p : pipes)
            finished = finished && p->loop->finished();
        if (finished) break;
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
        for (const auto& p : pipes) {
            if (stop.load(std::memory_order_relaxed) || p->platform->failed()) {
                for (const auto& q : pipes)
                    q->loop->requestStop();
            }
        }
        const auto now = std::chrono::steady_clock::now();
        const double dt = std::chrono::duration<double>(now - lastPrint).count();
        if (dt >= 1.0) {
            for (std::size_t i = 0; i < pipes.size(); ++i) {
                lastEmitted[i] =
                    printLiveStatus(status, *pipes[i]->loop, dt, lastEmitted[i], pipes[i]->label);
            }
            lastPrint = now;
        }
    }
    for (const auto& p : pipes)
        p->loop->join();
    const bool interrupted = stop.load(std::memory_order_relaxed);
    // Shutdown: close every device and file (renames temporaries into place).
    int closeFailures = 0;
    bool failed = false, outputFailed = false;
    for (const auto& p : pipes) {
        for (auto& s : p->sinks)
            closeFailures += s->close() != 0 ? 1 : 0;
        for (FrameSink* s : p->callerSinks)
            closeFailures += s->close() != 0 ? 1 : 0;
        printSummary(status, p->label.empty() ? sc.name : sc.name + ": " + p->label, *p->loop,
                     *p->platform, p->sinks);
        if (p->platform->failed())
            std::fprintf(status, "nvstim run: stopped: bad telemetry input\n");
        failed = failed || !p->loop->failure().empty() || p->platform->failed();
        // Bit 4: an output failed, or lost a frame to a write error (a frame file on a full
        // disk); frames a slow consumer's queue could not take are counted (queue drops), not
        // failures.
        const RunCounters& rc = p->loop->stats().counters;
        outputFailed = outputFailed || rc.outputsFailed > 0 || rc.sinkErrors > 0;
        if (!p->label.empty() && p->loop->faultDrops() > 0) {
            std::fprintf(status, "nvstim run: %s: %lld frames dropped by the drop fault\n",
                         p->label.c_str(), static_cast<long long>(p->loop->faultDrops()));
        }
    }
    if (req.statsPath && writeStats(req, pipes, interrupted, status) != 0) return kRunFailed;
    if (failed) return kRunFailed;
    outputFailed = outputFailed || closeFailures > 0;
    if (outputFailed)
        std::fprintf(status, "nvstim run: an output failed or had write errors (exit status 4)\n");
    return (outputFailed ? kRunOutputFailed : 0) | (interrupted ? kRunInterrupted : 0);
}

std::string jsonEscape(const std::string& in) {
    std::string out;
    for (const char c : in) {
        if (c == '"' || c == '\\') {
            out += '\\';
            out += c;
        } else if (static_cast<unsigned char>(c) < 0x20) {
            char b[8];
            std::snprintf(b, sizeof b, "\\u%04x", c);
            out += b;
        } else {
            out += c;
        }
    }
    return out;
}

}  // namespace nvs::rt
