// nvstimsrc (docs/gstreamer.md): a GstPushSrc that pulls the frames of an `nvstim run` from an
// rt::Session. GStreamer's C code calls every function here; no C++ exception leaves one (each
// catches and posts an element error instead).

#include "rt/gst/nvstim_src.h"

#include <dlfcn.h>
#include <gst/video/video.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <mutex>
#include <string>

#include "rt/clock/clock.h"
#include "rt/gst/src_settings.h"
#include "sim/core/error.h"

GST_DEBUG_CATEGORY_STATIC(gst_nvstim_src_debug);
#define GST_CAT_DEFAULT gst_nvstim_src_debug

namespace {

using nvs::gst::SrcSettings;
using nvs::rt::ClockKind;

// What one start()..stop() holds, and the settings (under the object lock).
struct SrcState {
    SrcSettings settings;
    std::mutex sessionMutex;  // the session pointer, between start/stop and unlock
    std::unique_ptr<nvs::rt::Session> session;
    std::atomic<bool> flushing{false};
    nvs::rt::PulledFrame frame;
    GstCaps* caps = nullptr;  // the fixed caps of the run (under the object lock)
    GstVideoInfo info{};
    bool live = true;
    bool interlaced = false, topFieldFirst = true;
    GstClockTime period_ns = 0;
    std::int64_t lastIndex = -1;
    std::int64_t pushed = 0, early = 0, repeats = 0;
};

// The frames a live source can hold before they are lost: the session's ring.
constexpr int kRingDepth = 4;
// A live source's latency in frame periods. The run emits frame k at its tick, which is its
// exposure mid-time t_sample_s: measured 0.1-0.5 ms later, a few ms at worst, on a 2-core
// machine (GST_DEBUG=nvstimsrc:6 logs it per frame). One period covers that, as a camera
// source's latency does.
constexpr GstClockTime kLatencyPeriods = 1;

}  // namespace

// GObject's instance struct; its name is GObject's convention (G_DECLARE_FINAL_TYPE).
struct _GstNvstimSrc {  // NOLINT(readability-identifier-naming)
    GstPushSrc parent;
    SrcState* state;
};

namespace {
// The parent class (GstPushSrc's), for chaining up; set by classInit.
gpointer parentClass = nullptr;
}  // namespace

namespace {

enum Prop : guint {
    kPropZero,
    kPropScenario,
    kPropChannel,
    kPropClock,
    kPropFrames,
    kPropCamera,
    kPropSet,
    kPropTelemetry,
    kPropConfigDir,
    kPropCacheDir,
};

constexpr gint64 kMaxFrames = 100'000'000'000LL;  // `nvstim run --frames`' bound

GstStaticPadTemplate srcTemplate =
    GST_STATIC_PAD_TEMPLATE("src", GST_PAD_SRC, GST_PAD_ALWAYS,
                            GST_STATIC_CAPS(GST_VIDEO_CAPS_MAKE("{ GRAY8, GRAY16_LE }")));

SrcState& stateOf(gpointer self) {
    return *GST_NVSTIM_SRC(self)->state;
}

// The folder of this plugin's file ("" where dladdr cannot say).
std::filesystem::path pluginDir() {
    static const char kAnchor = 0;
    Dl_info info{};
    if (dladdr(&kAnchor, &info) == 0 || info.dli_fname == nullptr) return {};
    std::error_code ec;
    const std::filesystem::path p = std::filesystem::absolute(info.dli_fname, ec);
    return ec ? std::filesystem::path() : p.parent_path();
}

// A string property's value for the settings (NULL: not set).
std::string stringOf(const GValue* value) {
    const gchar* s = g_value_get_string(value);
    return s != nullptr ? std::string(s) : std::string();
}

void setProperty(GObject* object, guint id, const GValue* value, GParamSpec* pspec) {
    SrcState& st = stateOf(object);
    bool live = false, setLive = false;
    GST_OBJECT_LOCK(object);
    SrcSettings& s = st.settings;
    switch (id) {
        case kPropScenario:
            s.scenario = stringOf(value);
            break;
        case kPropChannel:
            s.channel = stringOf(value);
            break;
        case kPropClock:
            s.clock = g_value_get_enum(value) == 0 ? ClockKind::Sim : ClockKind::Wall;
            live = s.clock == ClockKind::Wall;
            setLive = true;
            break;
        case kPropFrames:
            s.frames = g_value_get_int64(value);
            break;
        case kPropCamera:
            s.camera = stringOf(value);
            break;
        case kPropSet:
            s.sets = stringOf(value);
            break;
        case kPropTelemetry:
            s.telemetry = stringOf(value);
            break;
        case kPropConfigDir:
            s.configDir = stringOf(value);
            break;
        case kPropCacheDir:
            s.cacheDir = stringOf(value);
            break;
        default:
            G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
            break;
    }
    GST_OBJECT_UNLOCK(object);
    // A live source says so before READY -> PAUSED (GstBaseSrc then answers NO_PREROLL).
    if (setLive) gst_base_src_set_live(GST_BASE_SRC(object), live ? TRUE : FALSE);
}

// A settings string as a property value (NULL when empty).
void setString(GValue* value, const std::string& s) {
    g_value_set_string(value, s.empty() ? nullptr : s.c_str());
}

void getProperty(GObject* object, guint id, GValue* value, GParamSpec* pspec) {
    SrcState& st = stateOf(object);
    GST_OBJECT_LOCK(object);
    const SrcSettings& s = st.settings;
    switch (id) {
        case kPropScenario:
            setString(value, s.scenario);
            break;
        case kPropChannel:
            setString(value, s.channel);
            break;
        case kPropClock:
            g_value_set_enum(value, s.clock == ClockKind::Sim ? 0 : 1);
            break;
        case kPropFrames:
            g_value_set_int64(value, s.frames);
            break;
        case kPropCamera:
            setString(value, s.camera);
            break;
        case kPropSet:
            setString(value, s.sets);
            break;
        case kPropTelemetry:
            setString(value, s.telemetry);
            break;
        case kPropConfigDir:
            setString(value, s.configDir);
            break;
        case kPropCacheDir:
            setString(value, s.cacheDir);
            break;
        default:
            G_OBJECT_WARN_INVALID_PROPERTY_ID(object, id, pspec);
            break;
    }
    GST_OBJECT_UNLOCK(object);
}

// The run's format as fixed caps: GRAY8 up to 8 bits, else GRAY16_LE; the frame rate as the
// exact fraction the run ticks at; the pixels' aspect as the y4m output's A tag; interleaved
// with its field order for an interlaced run.
GstCaps* runCaps(const nvs::rt::Session& s) {
    const nvs::msg::FrameRate rate = nvs::msg::FrameRate::fromHz(s.frameRate_hz());
    const nvs::msg::FieldOrder order = s.fieldOrder();
    const bool interlaced = order != nvs::msg::FieldOrder::Progressive;
    GstCaps* caps = gst_caps_new_simple(
        "video/x-raw", "format", G_TYPE_STRING, s.bits() <= 8 ? "GRAY8" : "GRAY16_LE", "width",
        G_TYPE_INT, s.width(), "height", G_TYPE_INT, s.height(), "framerate", GST_TYPE_FRACTION,
        static_cast<gint>(rate.num), static_cast<gint>(rate.den), "pixel-aspect-ratio",
        GST_TYPE_FRACTION, s.pixelAspectNum(), s.pixelAspectDen(), "interlace-mode", G_TYPE_STRING,
        interlaced ? "interleaved" : "progressive", nullptr);
    if (interlaced) {
        gst_caps_set_simple(
            caps, "field-order", G_TYPE_STRING,
            order == nvs::msg::FieldOrder::TopFirst ? "top-field-first" : "bottom-field-first",
            nullptr);
    }
    return caps;
}

// Opens the run. A setup error posts the line `nvstim run` prints; false then.
bool openSession(GstBaseSrc* src) {
    SrcState& st = stateOf(src);
    try {
        GST_OBJECT_LOCK(src);
        const SrcSettings settings = st.settings;
        GST_OBJECT_UNLOCK(src);
        nvs::rt::SessionOptions opts = nvs::gst::sessionOptions(settings, pluginDir());
        opts.depth = kRingDepth;
        GST_INFO_OBJECT(src, "scenario %s, config %s, cache %s", opts.scenario.c_str(),
                        opts.dirs.config.c_str(), opts.dirs.cache.c_str());
        auto session = std::make_unique<nvs::rt::Session>(opts);
        GstCaps* caps = runCaps(*session);
        if (!gst_video_info_from_caps(&st.info, caps)) {
            gst_caps_unref(caps);
            throw nvs::SetupError("the run's format has no GStreamer video format");
        }
        st.live = settings.clock != ClockKind::Sim;
        st.interlaced = session->fieldOrder() != nvs::msg::FieldOrder::Progressive;
        st.topFieldFirst = session->fieldOrder() == nvs::msg::FieldOrder::TopFirst;
        st.period_ns = gst_util_uint64_scale(GST_SECOND, static_cast<guint64>(st.info.fps_d),
                                             static_cast<guint64>(st.info.fps_n));
        st.lastIndex = -1;
        st.pushed = st.early = st.repeats = 0;
        st.flushing.store(false);
        gchar* text = gst_caps_to_string(caps);
        GST_INFO_OBJECT(src, "run '%s': %d bits, %s", session->name().c_str(), session->bits(),
                        text);
        g_free(text);
        GST_OBJECT_LOCK(src);
        if (st.caps != nullptr) gst_caps_unref(st.caps);
        st.caps = caps;
        GST_OBJECT_UNLOCK(src);
        std::lock_guard<std::mutex> lock(st.sessionMutex);
        st.session = std::move(session);
        return true;
    } catch (const nvs::SetupError& e) {
        GST_ELEMENT_ERROR(src, RESOURCE, SETTINGS, ("nvstim: %s", e.what()), (nullptr));
    } catch (const std::exception& e) {
        GST_ELEMENT_ERROR(src, RESOURCE, FAILED, ("nvstim: error: %s", e.what()), (nullptr));
    }
    return false;
}

// READY -> PAUSED opens the run before GstBaseSrc starts, so that a setup error fails the state
// change with nvstim's message alone (a failed start() adds GstBaseSrc's own "Failed to start").
GstStateChangeReturn changeState(GstElement* element, GstStateChange transition) {
    if (transition == GST_STATE_CHANGE_READY_TO_PAUSED) {
        SrcState& st = stateOf(element);
        bool open = false;
        {
            std::lock_guard<std::mutex> lock(st.sessionMutex);
            open = st.session != nullptr;
        }
        if (!open && !openSession(GST_BASE_SRC(element))) return GST_STATE_CHANGE_FAILURE;
    }
    return GST_ELEMENT_CLASS(parentClass)->change_state(element, transition);
}

// GstBaseSrc's start: the run opened by changeState (or here, where GstBaseSrc starts again
// without a state change).
gboolean start(GstBaseSrc* src) {
    SrcState& st = stateOf(src);
    {
        std::lock_guard<std::mutex> lock(st.sessionMutex);
        if (st.session != nullptr) return TRUE;
    }
    return openSession(src) ? TRUE : FALSE;
}

// Ends the run (PAUSED -> READY; the streaming thread has stopped).
gboolean stop(GstBaseSrc* src) {
    SrcState& st = stateOf(src);
    std::unique_ptr<nvs::rt::Session> session;
    {
        std::lock_guard<std::mutex> lock(st.sessionMutex);
        session = std::move(st.session);
    }
    try {
        if (session) {
            const int rc = session->finish(true);
            GST_INFO_OBJECT(src,
                            "run ended with status %d: %" G_GINT64_FORMAT
                            " frames pushed, %" G_GINT64_FORMAT
                            " before PLAYING and %" G_GINT64_FORMAT " repeats left out",
                            rc, st.pushed, st.early, st.repeats);
        }
        session.reset();
    } catch (const std::exception& e) {
        GST_ELEMENT_ERROR(src, RESOURCE, CLOSE, ("nvstim: error: %s", e.what()), (nullptr));
        return FALSE;
    }
    GST_OBJECT_LOCK(src);
    if (st.caps != nullptr) gst_caps_unref(st.caps);
    st.caps = nullptr;
    GST_OBJECT_UNLOCK(src);
    return TRUE;
}

// Wakes a create() waiting for a frame: the run is stopped (Session::stop), and cannot go on
// after a flush.
gboolean unlock(GstBaseSrc* src) {
    SrcState& st = stateOf(src);
    st.flushing.store(true);
    std::lock_guard<std::mutex> lock(st.sessionMutex);
    if (st.session) st.session->stop();
    return TRUE;
}

gboolean unlockStop(GstBaseSrc* src) {
    stateOf(src).flushing.store(false);
    return TRUE;
}

GstCaps* getCaps(GstBaseSrc* src, GstCaps* filter) {
    SrcState& st = stateOf(src);
    GST_OBJECT_LOCK(src);
    GstCaps* caps = st.caps != nullptr ? gst_caps_ref(st.caps) : nullptr;
    GST_OBJECT_UNLOCK(src);
    if (caps == nullptr) caps = gst_pad_get_pad_template_caps(GST_BASE_SRC_PAD(src));
    if (filter != nullptr) {
        GstCaps* both = gst_caps_intersect_full(filter, caps, GST_CAPS_INTERSECT_FIRST);
        gst_caps_unref(caps);
        caps = both;
    }
    return caps;
}

// A live source's latency: kLatencyPeriods at least; the ring holds kRingDepth frames more
// before it loses one.
gboolean query(GstBaseSrc* src, GstQuery* q) {
    SrcState& st = stateOf(src);
    if (GST_QUERY_TYPE(q) == GST_QUERY_LATENCY && st.live && st.period_ns > 0) {
        const GstClockTime min = kLatencyPeriods * st.period_ns;
        gst_query_set_latency(q, TRUE, min, min + kRingDepth * st.period_ns);
        return TRUE;
    }
    return GST_BASE_SRC_CLASS(parentClass)->query(src, q);
}

// The pipeline clock's time less CLOCK_MONOTONIC's [ns]: 0 for GStreamer's system clock on
// CLOCK_MONOTONIC (the default), else the two read now, the pipeline clock between two reads of
// CLOCK_MONOTONIC (their mean is when it was read).
std::int64_t clockOffset_ns(GstClock* clock) {
    if (GST_IS_SYSTEM_CLOCK(clock)) {
        GstClockType type = GST_CLOCK_TYPE_REALTIME;
        g_object_get(clock, "clock-type", &type, nullptr);
        if (type == GST_CLOCK_TYPE_MONOTONIC) return 0;
    }
    const std::int64_t before_ns = nvs::rt::monotonicNow_ns();
    const auto clock_ns = static_cast<std::int64_t>(gst_clock_get_time(clock));
    const std::int64_t after_ns = nvs::rt::monotonicNow_ns();
    return clock_ns - (before_ns + (after_ns - before_ns) / 2);
}

// The pipeline's running time [ns] of a frame's exposure mid-time under the wall clock: the
// CLOCK_MONOTONIC instant, moved onto the pipeline clock, less the base time. Negative: exposed
// before the pipeline started playing.
bool liveTimestamp(GstElement* el, const nvs::rt::PulledFrame& f, std::int64_t* running_ns) {
    GstClock* clock = gst_element_get_clock(el);
    if (clock == nullptr) return false;
    const std::int64_t offset_ns = clockOffset_ns(clock);
    gst_object_unref(clock);
    const auto base_ns = static_cast<std::int64_t>(gst_element_get_base_time(el));
    *running_ns = nvs::gst::exposureMonotonic_ns(f) + offset_ns - base_ns;
    return true;
}

// The end of the run: EOS, or an error when the run failed.
GstFlowReturn endOfRun(GstBaseSrc* src, SrcState& st, nvs::rt::Session& session) {
    if (st.flushing.load()) return GST_FLOW_FLUSHING;
    const int rc = session.finish(false);
    if (rc == nvs::rt::kRunFailed) {
        GST_ELEMENT_ERROR(src, STREAM, FAILED, ("nvstim: the run failed (exit status %d)", rc),
                          (nullptr));
        return GST_FLOW_ERROR;
    }
    return GST_FLOW_EOS;
}

GstFlowReturn create(GstPushSrc* psrc, GstBuffer** out) {
    GstBaseSrc* src = GST_BASE_SRC(psrc);
    SrcState& st = stateOf(psrc);
    try {
        nvs::rt::Session* session = nullptr;
        {
            std::lock_guard<std::mutex> lock(st.sessionMutex);
            session = st.session.get();
        }
        if (session == nullptr) return GST_FLOW_FLUSHING;
        nvs::rt::PulledFrame& f = st.frame;
        std::int64_t pts_ns = 0;
        for (;;) {
            if (st.flushing.load()) return GST_FLOW_FLUSHING;
            if (!session->next(f)) return endOfRun(src, st, *session);
            // A repeat (the wall clock's late policy) is the last frame sent again: a GStreamer
            // sink keeps showing it anyway.
            if (f.repeat) {
                ++st.repeats;
                continue;
            }
            if (!st.live) {
                pts_ns = std::llround(f.t_sample_s * 1e9);
                break;
            }
            if (!liveTimestamp(GST_ELEMENT(src), f, &pts_ns)) {
                GST_ELEMENT_ERROR(src, CORE, CLOCK, ("nvstim: no pipeline clock"), (nullptr));
                return GST_FLOW_ERROR;
            }
            GST_LOG_OBJECT(src, "frame %" G_GINT64_FORMAT ": emitted %.3f ms after its exposure",
                           f.index, (f.emit_s - f.t_sample_s) * 1e3);
            if (pts_ns >= 0) break;
            ++st.early;  // exposed before PLAYING: held in the ring while PAUSED
        }
        GstBuffer* buf = gst_buffer_new_allocate(nullptr, GST_VIDEO_INFO_SIZE(&st.info), nullptr);
        GstMapInfo map;
        if (buf == nullptr || !gst_buffer_map(buf, &map, GST_MAP_WRITE)) {
            if (buf != nullptr) gst_buffer_unref(buf);
            GST_ELEMENT_ERROR(src, RESOURCE, NO_SPACE_LEFT, ("nvstim: no memory for a frame"),
                              (nullptr));
            return GST_FLOW_ERROR;
        }
        nvs::gst::packGray(f, map.data,
                           static_cast<std::size_t>(GST_VIDEO_INFO_PLANE_STRIDE(&st.info, 0)));
        gst_buffer_unmap(buf, &map);
        GST_BUFFER_PTS(buf) = pts_ns >= 0 ? static_cast<GstClockTime>(pts_ns) : GST_CLOCK_TIME_NONE;
        GST_BUFFER_DTS(buf) = GST_CLOCK_TIME_NONE;
        GST_BUFFER_DURATION(buf) = st.period_ns;
        GST_BUFFER_OFFSET(buf) = static_cast<guint64>(f.index);
        GST_BUFFER_OFFSET_END(buf) = static_cast<guint64>(f.index + 1);
        if (st.lastIndex >= 0 && f.index != st.lastIndex + 1) {
            GST_BUFFER_FLAG_SET(buf, GST_BUFFER_FLAG_DISCONT);
        }
        if (st.interlaced) {
            GST_BUFFER_FLAG_SET(buf, GST_VIDEO_BUFFER_FLAG_INTERLACED);
            if (st.topFieldFirst) GST_BUFFER_FLAG_SET(buf, GST_VIDEO_BUFFER_FLAG_TFF);
        }
        st.lastIndex = f.index;
        ++st.pushed;
        *out = buf;
        return GST_FLOW_OK;
    } catch (const std::exception& e) {
        GST_ELEMENT_ERROR(src, STREAM, FAILED, ("nvstim: error: %s", e.what()), (nullptr));
        return GST_FLOW_ERROR;
    }
}

void finalize(GObject* object) {
    GstNvstimSrc* self = GST_NVSTIM_SRC(object);
    if (self->state->caps != nullptr) gst_caps_unref(self->state->caps);
    delete self->state;  // a session still open is stopped and joined by its destructor
    self->state = nullptr;
    G_OBJECT_CLASS(parentClass)->finalize(object);
}

GParamSpec* stringSpec(const char* name, const char* blurb) {
    return g_param_spec_string(name, name, blurb, nullptr,
                               static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
                                                        GST_PARAM_MUTABLE_READY));
}

}  // namespace

extern "C" GType gst_nvstim_clock_get_type(void) {
    static GType type = 0;
    static const GEnumValue kValues[] = {
        {0, "Simulated: every frame, as fast as it can (non-live)", "sim"},
        {1, "Wall: real time (a live source)", "wall"},
        {0, nullptr, nullptr},
    };
    if (g_once_init_enter(&type)) {
        g_once_init_leave(&type, g_enum_register_static("GstNvstimClock", kValues));
    }
    return type;
}

namespace {

void classInit(gpointer klass, gpointer /*data*/) {
    parentClass = g_type_class_peek_parent(klass);
    GObjectClass* gobject = G_OBJECT_CLASS(klass);
    GstElementClass* element = GST_ELEMENT_CLASS(klass);
    GstBaseSrcClass* base = GST_BASE_SRC_CLASS(klass);
    GstPushSrcClass* push = GST_PUSH_SRC_CLASS(klass);
    GST_DEBUG_CATEGORY_INIT(gst_nvstim_src_debug, "nvstimsrc", 0, "nvstim scenario source");

    gobject->set_property = setProperty;
    gobject->get_property = getProperty;
    gobject->finalize = finalize;
    const auto flags = static_cast<GParamFlags>(G_PARAM_READWRITE | G_PARAM_STATIC_STRINGS |
                                                GST_PARAM_MUTABLE_READY);
    g_object_class_install_property(
        gobject, kPropScenario,
        stringSpec("scenario", "Scenario folder or .toml file (as `nvstim run SCENARIO`)"));
    g_object_class_install_property(
        gobject, kPropChannel,
        stringSpec("channel", "A rig's channel by name (unset: one camera)"));
    g_object_class_install_property(
        gobject, kPropClock,
        g_param_spec_enum("clock", "clock", "The run's clock (as `nvstim run --clock`)",
                          GST_TYPE_NVSTIM_CLOCK, 1, flags));
    g_object_class_install_property(
        gobject, kPropFrames,
        g_param_spec_int64("frames", "frames",
                           "Frames to run (-1: the scenario's duration, as `nvstim run` without "
                           "--frames)",
                           -1, kMaxFrames, -1, flags));
    g_object_class_install_property(
        gobject, kPropCamera,
        stringSpec("camera",
                   "Camera preset (name or .toml path) in place of the scenario's "
                   "(as `nvstim run --camera`)"));
    g_object_class_install_property(
        gobject, kPropSet,
        stringSpec("set",
                   "Camera preset overrides KEY=VALUE, separated by ',' or ';' (as "
                   "`nvstim run --set` for each)"));
    g_object_class_install_property(
        gobject, kPropTelemetry,
        stringSpec("telemetry", "Telemetry source spec (as `nvstim run --telemetry`)"));
    g_object_class_install_property(
        gobject, kPropConfigDir,
        stringSpec("config-dir",
                   "Configuration folder (unset: $NVS_CONFIG_DIR, else the "
                   "installed share/nvstim/config, else the source tree's)"));
    g_object_class_install_property(gobject, kPropCacheDir,
                                    stringSpec("cache-dir",
                                               "Cache folder (unset: $NVS_CACHE_DIR, else "
                                               "$XDG_CACHE_HOME/nvstim, else ~/.cache/nvstim)"));

    gst_element_class_set_static_metadata(
        element, "nvstim scenario source", "Source/Video",
        "Frames of an nvstim run of a scenario (night-vision camera simulation), time-stamped "
        "at their exposure mid-times",
        "nvstim");
    gst_element_class_add_static_pad_template(element, &srcTemplate);
    element->change_state = changeState;

    base->start = start;
    base->stop = stop;
    base->unlock = unlock;
    base->unlock_stop = unlockStop;
    base->get_caps = getCaps;
    base->query = query;
    push->create = create;
}

void instanceInit(GTypeInstance* instance, gpointer /*klass*/) {
    GstNvstimSrc* self = GST_NVSTIM_SRC(instance);
    self->state = new SrcState();
    gst_base_src_set_format(GST_BASE_SRC(self), GST_FORMAT_TIME);
    gst_base_src_set_live(GST_BASE_SRC(self), TRUE);  // the default clock is the wall clock
}

}  // namespace

// GObject's type of the element (G_DEFINE_TYPE's work, written out: its casts of the init
// functions are C's).
extern "C" GType gst_nvstim_src_get_type(void) {
    static GType type = 0;
    if (g_once_init_enter(&type)) {
        g_once_init_leave(&type, g_type_register_static_simple(
                                     GST_TYPE_PUSH_SRC, g_intern_static_string("GstNvstimSrc"),
                                     sizeof(GstNvstimSrcClass), classInit, sizeof(GstNvstimSrc),
                                     instanceInit, static_cast<GTypeFlags>(0)));
    }
    return type;
}
