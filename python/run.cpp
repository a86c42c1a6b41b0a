// nvstim.Run and nvstim.Frame: a scenario run whose frames Python pulls (rt/session/session.h).
// Each frame's counts become a numpy array over the frame's own buffer (countsArray: no copy);
// its metadata, the record the run's meta: output writes, a dict (Python's json module).

#include <pybind11/stl.h>

#include <atomic>
#include <mutex>

#include "python/bindings.h"
#include "rt/cli/data_dirs.h"
#include "rt/session/session.h"
#include "sim/core/error.h"
#include "sim/sensor/camera.h"

namespace nvs::py {

namespace {

// One pulled frame as Python sees it.
struct Frame {
    pb::array counts;  // (height, width), uint8 (bits ≤ 8) or uint16
    pb::object meta;   // dict
    std::int64_t index = 0, tick = 0, emitMonotonic_ns = 0;
    double t_sample_s = 0.0, exposure_s = 0.0, emit_s = 0.0;
    bool repeat = false;
};

const char* fieldOrderName(msg::FieldOrder order) {
    switch (order) {
        case msg::FieldOrder::TopFirst:
            return "top";
        case msg::FieldOrder::BottomFirst:
            return "bottom";
        case msg::FieldOrder::Progressive:
            break;
    }
    return "progressive";
}

class Run {
  public:
    Run(const std::string& scenario, const std::string& clock, std::optional<std::int64_t> frames,
        const std::optional<std::string>& camera, const pb::dict& sets, const std::string& channel,
        const std::vector<std::string>& outputs, const std::optional<std::string>& telemetry,
        int depth, bool status, const std::optional<std::string>& configDir,
        const std::optional<std::string>& cacheDir) {
        rt::SessionOptions o;
        // As `nvstim run`: the data folders, then the scenario (a path, or a shipped scenario's
        // bare name), then the rest.
        o.dirs = moduleDataDirs(configDir, cacheDir);
        o.scenario = cli::resolveScenario(scenario, cli::scenariosDir(o.dirs));
        if (clock == "sim")
            o.clock = rt::ClockKind::Sim;
        else if (clock == "wall")
            o.clock = rt::ClockKind::Wall;
        else
            throw SetupError("clock '" + clock + "': must be sim or wall");
        if (frames && *frames < 1) throw SetupError("frames must be >= 1 (None: the duration)");
        o.frames = frames;
        o.channel = channel;
        o.overrides.cameraPreset = camera;
        o.overrides.cameraSets = presetOverrides(sets);
        o.outputs = outputs;
        o.telemetry = telemetry;
        o.depth = depth;
        o.statusLines = status;
        json_ = pb::module_::import("json").attr("loads");
        // Setup renders nothing yet but reads the scene: without the GIL.
        pb::gil_scoped_release nogil;
        session_ = std::make_unique<rt::Session>(o);
    }
    ~Run() {
        pb::gil_scoped_release nogil;
        close();
    }

    const rt::Session& session() const { return *session_; }

    // The next frame; StopIteration at the end of the run (or after close()).
    Frame next() {
        rt::PulledFrame f;  // a fresh buffer: the last one now belongs to its array
        bool got = false;
        {
            pb::gil_scoped_release nogil;
            std::lock_guard<std::mutex> lock(closeMutex_);
            got = !closed_ && session_->next(f);
            if (!got && !closed_) ended_.store(true);
        }
        if (!got) throw pb::stop_iteration();
        Frame out;
        out.index = f.index;
        out.tick = f.tick;
        out.emitMonotonic_ns = f.emitMonotonic_ns;
        out.t_sample_s = f.t_sample_s;
        out.exposure_s = f.exposure_s;
        out.emit_s = f.emit_s;
        out.repeat = f.repeat;
        out.meta = json_(f.metaJson);
        out.counts = countsArray(std::move(f.counts), {f.height, f.width}, f.bits);
        return out;
    }

    // Ends the run (stopping it first unless every frame was taken) and joins it; its exit
    // status (docs/contracts.md, "Exit statuses"). Idempotent.
    int close() {
        // A frame another thread waits for in next() (holding the lock) comes, or the run's
        // end does, once the run is stopped: stopped before the lock is taken.
        if (!ended_.load()) session_->stop();
        std::lock_guard<std::mutex> lock(closeMutex_);
        if (!closed_.load()) status_.store(session_->finish(!ended_.load()));
        closed_.store(true);
        return status_.load();
    }
    int closeWithoutGil() {
        pb::gil_scoped_release nogil;
        return close();
    }
    std::optional<int> exitStatus() const {
        if (!closed_.load()) return std::nullopt;
        return status_.load();
    }

  private:
    std::unique_ptr<rt::Session> session_;
    pb::object json_;
    // next() and close() from two Python threads: one at a time (the session's finish() is not
    // for two callers).
    std::mutex closeMutex_;
    std::atomic<bool> closed_{false};
    std::atomic<bool> ended_{false};  // next() saw the end: every frame taken
    std::atomic<int> status_{0};
};

}  // namespace

void bindRun(pb::module_& m) {
    pb::class_<Frame>(m, "Frame", "One frame of a Run: counts (numpy, no copy) and metadata.")
        .def_readonly("counts", &Frame::counts,
                      "(height, width) numpy array of the ADC counts: uint8 for a camera of at "
                      "most 8 bits (the y4m output's bytes), else uint16 (the counts; y4m "
                      "scales them to 16 bits). Views the frame's own buffer (no copy).")
        .def_readonly("meta", &Frame::meta, "The meta: output's record of this frame (a dict).")
        .def_readonly("index", &Frame::index, "Frame number (meta 'frame').")
        .def_readonly("tick", &Frame::tick)
        .def_readonly("t_sample_s", &Frame::t_sample_s, "Exposure mid-time on the run clock [s].")
        .def_readonly("exposure_s", &Frame::exposure_s)
        .def_readonly("emit_s", &Frame::emit_s, "Run-clock time of emission [s].")
        .def_readonly("emit_monotonic_ns", &Frame::emitMonotonic_ns,
                      "CLOCK_MONOTONIC of emission [ns] (0 under the sim clock).")
        .def_readonly("repeat", &Frame::repeat, "A late frame's repeat of the previous one.")
        .def("__repr__", [](const Frame& f) {
            return "<nvstim.Frame " + std::to_string(f.index) +
                   " t_sample_s=" + std::to_string(f.t_sample_s) + ">";
        });

    pb::class_<Run>(m, "Run", "A scenario run whose frames are pulled one at a time.")
        .def(pb::init<const std::string&, const std::string&, std::optional<std::int64_t>,
                      const std::optional<std::string>&, const pb::dict&, const std::string&,
                      const std::vector<std::string>&, const std::optional<std::string>&, int, bool,
                      const std::optional<std::string>&, const std::optional<std::string>&>(),
             pb::arg("scenario"), pb::kw_only(), pb::arg("clock") = "sim",
             pb::arg("frames") = pb::none(), pb::arg("camera") = pb::none(),
             pb::arg("set") = pb::dict(), pb::arg("channel") = "",
             pb::arg("outputs") = std::vector<std::string>(), pb::arg("telemetry") = pb::none(),
             pb::arg("depth") = 4, pb::arg("status") = false, pb::arg("config_dir") = pb::none(),
             pb::arg("cache_dir") = pb::none())
        .def_property_readonly("width", [](const Run& r) { return r.session().width(); })
        .def_property_readonly("height", [](const Run& r) { return r.session().height(); })
        .def_property_readonly("bits", [](const Run& r) { return r.session().bits(); })
        .def_property_readonly("frame_rate_hz",
                               [](const Run& r) { return r.session().frameRate_hz(); })
        .def_property_readonly(
            "field_order", [](const Run& r) { return fieldOrderName(r.session().fieldOrder()); })
        .def_property_readonly("frames",
                               [](const Run& r) -> std::optional<std::int64_t> {
                                   const std::int64_t n = r.session().frames();
                                   if (n < 0) return std::nullopt;
                                   return n;
                               })
        .def_property_readonly("name", [](const Run& r) { return r.session().name(); })
        .def_property_readonly("exit_status", &Run::exitStatus,
                               "The run's exit status once closed (None before).")
        .def("__iter__", [](Run& r) -> Run& { return r; })
        .def("__next__", &Run::next)
        .def("close", &Run::closeWithoutGil,
             "Ends the run (stops it unless every frame was taken); its exit status.")
        .def("__enter__", [](Run& r) -> Run& { return r; })
        .def("__exit__", [](Run& r, const pb::args&) {
            r.closeWithoutGil();
            return false;
        });
}

}  // namespace nvs::py
