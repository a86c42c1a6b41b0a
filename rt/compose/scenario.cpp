#include "rt/compose/scenario.h"

#include <algorithm>
#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <ctime>

#include "sim/core/config.h"
#include "sim/core/input_file.h"
#include "sim/core/units.h"
#include "sim/thermal/thermal_config.h"

namespace nvs::rt {

int daysInMonth(int year, int month) {
    static constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
    const bool leap = (year % 4 == 0 && year % 100 != 0) || year % 400 == 0;
    return kDays[month - 1] + (month == 2 && leap ? 1 : 0);
}

bool parseIso8601Utc(const std::string& text, double* unix_s) {
    int Y = 0, M = 0, D = 0, h = 0, m = 0, consumed = 0;
    double s = 0.0;
    if (std::sscanf(text.c_str(), "%4d-%2d-%2dT%2d:%2d:%lf%n", &Y, &M, &D, &h, &m, &s, &consumed) !=
        6) {
        return false;
    }
    if (Y < 1000 || M < 1 || M > 12 || D < 1 || D > daysInMonth(Y, M) || h < 0 || h > 23 || m < 0 ||
        m > 59 || !(s >= 0.0 && s < 61.0)) {
        return false;  // no 31 February: the day must exist in its month
    }
    const std::string zone = text.substr(static_cast<std::size_t>(consumed));
    int offset_s = 0;
    if (zone == "Z" || zone.empty()) {
        offset_s = 0;
    } else {
        int oh = 0, om = 0;
        char sign = 0;
        if (std::sscanf(zone.c_str(), "%c%2d:%2d", &sign, &oh, &om) != 3 ||
            (sign != '+' && sign != '-') || oh < 0 || oh > 14 || om < 0 || om > 59) {
            return false;
        }
        offset_s = (sign == '-' ? -1 : 1) * (oh * 3600 + om * 60);
    }
    std::tm tm{};
    tm.tm_year = Y - 1900;
    tm.tm_mon = M - 1;
    tm.tm_mday = D;
    tm.tm_hour = h;
    tm.tm_min = m;
    tm.tm_sec = 0;
    const time_t t = timegm(&tm);
    *unix_s = static_cast<double>(t) + s - offset_s;
    return true;
}

namespace {

// A key of an optional table: its value, or the default when the table is absent.
template <typename T>
T getOr(const std::optional<ConfigTable>& t, std::string_view key, const T& def) {
    return t ? t->get<T>(key, def) : def;
}

void readIiccdCamera(const ConfigTable& t, std::optional<int> width, std::optional<int> height,
                     std::optional<int> bits, const std::filesystem::path& configDir,
                     sensor::Overrides ov, CameraSpec& out);
void readThermalCamera(const ConfigTable& t, std::optional<int> width, std::optional<int> height,
                       std::optional<int> bits, const std::filesystem::path& configDir,
                       sensor::Overrides ov, CameraSpec& out);

// [camera]: the preset with its overrides; the scenario's explicit size and ADC depth are
// applied as overrides so that the preset's own validation sees them.
// The command line's overrides (ScenarioOverrides) replace the preset and win over its set.
void readCamera(const ConfigTable& t, std::optional<int> width, std::optional<int> height,
                std::optional<int> bits, std::uint64_t defaultSeed,
                const std::filesystem::path& configDir, const ScenarioOverrides& given,
                CameraSpec& out) {
    out.preset = t.require<std::string>("preset");
    if (given.cameraPreset) out.preset = *given.cameraPreset;
    sensor::Overrides ov;
    try {
        ov = sensor::parseOverrides(t.get<std::vector<std::string>>("set", {}));
    } catch (const SetupError& e) {
        t.fail("set", e.what());
    }
    // width, height and video.adc_bits of the command line come as the format's (readFormat).
    for (const auto& [key, value] : given.cameraSets)
        if (key != "width" && key != "height" && key != "video.adc_bits") ov[key] = value;
    out.presetOverrides = ov;
    if (bolometer::isThermalPreset(configDir, out.preset)) {
        readThermalCamera(t, width, height, bits, configDir, ov, out);
    } else {
        readIiccdCamera(t, width, height, bits, configDir, ov, out);
    }
    const std::int64_t seed = t.get<std::int64_t>("seed", static_cast<std::int64_t>(defaultSeed));
    if (seed < 0) t.fail("seed", "must not be negative");
    out.seed = static_cast<std::uint64_t>(seed);
    const std::string controls = t.get<std::string>("controls", "platform");
    if (controls != "platform" && controls != "preset") {
        t.fail("controls", "must be \"platform\" or \"preset\"");
    }
    out.controlsFromPlatform = controls == "platform";
    out.enabled = true;
}

void readIiccdCamera(const ConfigTable& t, std::optional<int> width, std::optional<int> height,
                     std::optional<int> bits, const std::filesystem::path& configDir,
                     sensor::Overrides ov, CameraSpec& out) {
    const auto put = [&](const char* key, std::optional<int> v) {
        if (!v) return;
        if (ov.count(key) != 0) t.fail("set", std::string(key) + " is also given in [scenario]");
        ov[key] = std::to_string(*v);
    };
    put("width", width);
    put("height", height);
    put("video.adc_bits", bits);
    try {
        out.params = sensor::loadCamera(configDir, out.preset, ov);
    } catch (const SetupError& e) {
        t.fail("preset", e.what());
    }
    out.spectrum = t.get<std::string>("spectrum", "flat");
    try {
        (void)sensor::spectrumShape(configDir, out.spectrum);
    } catch (const SetupError& e) {
        t.fail("spectrum", e.what());
    }
}

// A thermal preset: the bolometer's parameters, and the loop's format in `params` (frame scan
// at the core's frame rate, its size, 8 bits of display or the raw ADC's depth).
void readThermalCamera(const ConfigTable& t, std::optional<int> width, std::optional<int> height,
                       std::optional<int> bits, const std::filesystem::path& configDir,
                       sensor::Overrides ov, CameraSpec& out) {
    if (width) ov["width"] = std::to_string(*width);
    if (height) ov["height"] = std::to_string(*height);
    try {
        out.thermalParams = bolometer::loadThermalCamera(configDir, out.preset, ov);
    } catch (const SetupError& e) {
        t.fail("preset", e.what());
    }
    const bolometer::ThermalCameraParams& tp = *out.thermalParams;
    if (bits && *bits != 8 && *bits != tp.adc_bits) {
        t.fail("preset", "a thermal camera gives 8 bits (display) or its ADC's " +
                             std::to_string(tp.adc_bits) + " bits (raw), not " +
                             std::to_string(*bits));
    }
    out.thermal = true;
    out.params = sensor::CameraParams{};
    out.params.width = tp.width;
    out.params.height = tp.height;
    out.params.scan = sensor::ScanMode::Frame;
    out.params.field_rate_Hz = 2.0 * tp.frame_rate_Hz;  // frame scan: the loop's rate is half
    out.params.adc_bits = bits ? *bits : 8;
    out.spectrum = "thermal";
}

double finiteIn(const ConfigTable& t, std::string_view key, double fallback, double lo, double hi) {
    const double v = t.get<double>(key, fallback);
    if (!std::isfinite(v) || v < lo || v > hi) {
        t.fail(key, "must lie in [" + std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    return v;
}

// [site], [atmosphere], [scene] of a rendered scenario (docs/scene.md).
void readSceneTables(const ConfigTable& root, const std::filesystem::path& file,
                     const std::filesystem::path& configDir, SceneSpec& out) {
    const ConfigTable site = root.table("site");
    out.site.lat_deg = finiteIn(site, "lat_deg", 0.0, -90.0, 90.0);
    out.site.lon_deg = finiteIn(site, "lon_deg", 0.0, -180.0, 360.0);
    out.site.height_m = finiteIn(site, "height_m", 0.0, -500.0, 9000.0);
    out.site.pressure_hPa = finiteIn(site, "pressure_hPa", 1013.25, 0.0, 1100.0);
    out.site.temperature_C = finiteIn(site, "temperature_C", 15.0, -80.0, 60.0);
    out.atmosphere.siteAltitude_m = out.site.height_m;
    if (const auto atOpt = root.optionalTable("atmosphere")) {
        const ConfigTable& at = *atOpt;
        out.atmosphere.visibility_km = finiteIn(at, "visibility_km", 23.0, 0.05, 500.0);
        if (at.contains("aerosol")) {
            out.atmosphere.aerosol =
                sky::parseAerosolModel(at.require<std::string>("aerosol"), at.location("aerosol"));
        }
        out.atmosphere.ozone_DU = finiteIn(at, "ozone_DU", 300.0, 0.0, 1000.0);
        out.atmosphere.precipitableWater_cm = finiteIn(at, "precipitable_water_cm", 1.5, 0.0, 10.0);
        out.atmosphere.cloudOpticalDepth = finiteIn(at, "cloud_optical_depth", 0.0, 0.0, 200.0);
        out.atmosphere.groundAlbedo = finiteIn(at, "ground_albedo", 0.15, 0.0, 1.0);
        out.lunarSkyScale = finiteIn(at, "lunar_sky_scale", 1.0, 0.0, 10.0);
    }
    const ConfigTable scn = root.table("scene");
    const auto rel = scn.require<std::string>("file");
    out.sceneFile = std::filesystem::absolute(file.parent_path() / rel);
    if (!pathExists(out.sceneFile)) {
        scn.fail("file", "scene file not found: " + out.sceneFile.string());
    }
    out.lampsOn = scn.optional<std::vector<std::string>>("lamps_on");
    if (const auto th = root.optionalTable("thermal")) {
        ThermalSpec ts;
        ts.loc = root.location("thermal");
        const auto w = th->require<std::string>("weather");
        ts.weatherFile = std::filesystem::absolute(file.parent_path() / w).lexically_normal();
        if (!pathExists(ts.weatherFile))
            th->fail("weather", "file not found: " + ts.weatherFile.string());
        ts.materialsFile = std::filesystem::absolute(
            th->contains("materials") ? file.parent_path() / th->require<std::string>("materials")
                                      : configDir / "thermal" / "materials.toml");
        if (!pathExists(ts.materialsFile)) {
            th->fail("materials", "file not found: " + ts.materialsFile.string());
        }
        ts.focalLength_mm = finiteIn(*th, "focal_length_mm", ts.focalLength_mm, 1.0, 1000.0);
        ts.heat = thermal::readHeatBalanceParams(*th);
        out.thermal = ts;
    }
    try {
        out.atmosphere.validate();
    } catch (const SetupError& e) {
        throw SetupError(root.location("atmosphere"), e.what());
    }
}

std::string hzText(double hz) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "%.6g", hz);
    return buf;
}

// The format of the frames: scan, rate, size, depth and exposure from `s` ([scenario], or a
// [[channel]]), and the camera from `cam` ([camera], or the same [[channel]]). One set of
// defaults: the camera preset's where there is one, else 320×240, 8 bits, 60 Hz progressive
// (30 Hz interlaced).
FrameFormat readFormat(const ConfigTable& s, const std::optional<ConfigTable>& cam,
                       std::uint64_t seed, const std::filesystem::path& configDir,
                       const ScenarioOverrides& given) {
    FrameFormat f;
    const std::optional<double> hzGiven = s.optional<double>("frame_rate_hz");
    std::optional<int> widthGiven = s.optional<int>("width");
    std::optional<int> heightGiven = s.optional<int>("height");
    std::optional<int> bitsGiven = s.optional<int>("bits");
    // The command line's --set width, height and video.adc_bits win over [scenario]'s: a user
    // shrinks a shipped scenario without copying it.
    const auto fromCommandLine = [&](const char* key, std::optional<int>& v) {
        const auto it = given.cameraSets.find(key);
        if (it == given.cameraSets.end()) return;
        char* end = nullptr;
        errno = 0;
        const long n = std::strtol(it->second.c_str(), &end, 10);
        if (end == it->second.c_str() || *end != '\0' || errno == ERANGE || n < 1 || n > 65536) {
            throw SetupError("--set " + it->first + "=" + it->second + ": not a positive integer");
        }
        v = static_cast<int>(n);
    };
    fromCommandLine("width", widthGiven);
    fromCommandLine("height", heightGiven);
    fromCommandLine("video.adc_bits", bitsGiven);
    if (cam) readCamera(*cam, widthGiven, heightGiven, bitsGiven, seed, configDir, given, f.camera);
    const sensor::CameraParams& cp = f.camera.params;
    // Scan follows the camera: a field-scan camera (RS-170, CCIR) delivers interlaced frames,
    // two fields each, every field exposed at its own time; a frame-scan camera, progressive.
    const bool fieldCamera = cam && cp.scan == sensor::ScanMode::Field;
    const std::string scan = s.get<std::string>("scan", fieldCamera ? "interlaced" : "progressive");
    if (scan != "progressive" && scan != "interlaced") {
        s.fail("scan", "must be \"progressive\" or \"interlaced\"");
    }
    f.scan = scan == "interlaced" ? ScanKind::Interlaced : ScanKind::Progressive;
    const bool interlaced = f.scan == ScanKind::Interlaced;
    if (interlaced && cam && cp.scan != sensor::ScanMode::Field) {
        s.fail("scan",
               "interlaced output needs a field-scan camera preset (the preset has "
               "scan = \"frame\")");
    }
    // Default rate: the preset's frame rate (interlaced: half its field rate), or its field
    // rate (progressive output of a field-scan camera: one frame per field, woven by the
    // camera, so each frame is the latest two fields).
    const bool fieldPerFrame = fieldCamera && !interlaced;
    const double camRate_hz = fieldPerFrame ? cp.field_rate_Hz : cp.field_rate_Hz / 2.0;
    const double hz = hzGiven ? *hzGiven : (cam ? camRate_hz : (interlaced ? 30.0 : 60.0));
    try {
        f.rate = FrameRate::fromHz(hz);
    } catch (const SetupError& e) {
        s.fail("frame_rate_hz", e.what());
    }
    if (fieldPerFrame && std::abs(f.rate.hz() - cp.field_rate_Hz) > 1e-3 * cp.field_rate_Hz) {
        // Otherwise each field would last a frame period: a camera that does not exist.
        s.fail("frame_rate_hz",
               "a field-scan camera in progressive scan emits one frame per field: the rate "
               "must be its field rate (" +
                   hzText(cp.field_rate_Hz) + " Hz), or set scan = \"interlaced\" for " +
                   hzText(cp.field_rate_Hz / 2.0) + " frames/s");
    }
    f.width = widthGiven ? *widthGiven : (cam ? cp.width : 320);
    f.height = heightGiven ? *heightGiven : (cam ? cp.height : 240);
    if (f.width < 8 || f.width > 8192) s.fail("width", "must be in [8, 8192]");
    if (f.height < 8 || f.height > 8192) s.fail("height", "must be in [8, 8192]");
    f.bits = bitsGiven ? *bitsGiven : (cam ? cp.adc_bits : 8);
    if (f.bits < 1 || f.bits > 16) s.fail("bits", "must be in [1, 16]");
    // The camera runs at the loop's rate: one call per emitted frame (progressive), or one per
    // field, two per emitted frame (interlaced).
    if (cam) f.camera.params.field_rate_Hz = fieldPerFrame ? f.rate.hz() : 2.0 * f.rate.hz();
    if (f.camera.thermal) f.camera.thermalParams->frame_rate_Hz = f.rate.hz();
    f.exposure_s = finiteIn(s, "exposure_s", 0.0, 0.0, 1000.0);
    return f;
}

void applyFormat(const FrameFormat& f, Scenario& sc) {
    sc.camera = f.camera;
    sc.rate = f.rate;
    sc.scan = f.scan;
    sc.width = f.width;
    sc.height = f.height;
    sc.bits = f.bits;
    sc.exposure_s = f.exposure_s;
}

// A [fwd, right, down] or [yaw, pitch, roll] array of three finite numbers within ±limit.
std::array<double, 3> triple(const ConfigTable& t, std::string_view key, double limit) {
    const auto v = t.get<std::vector<double>>(key, {0.0, 0.0, 0.0});
    if (v.size() != 3) t.fail(key, "needs three numbers");
    for (const double x : v) {
        if (!(std::fabs(x) <= limit)) {
            t.fail(key, "each must be finite and within ±" + hzText(limit));
        }
    }
    return {v[0], v[1], v[2]};
}

// [[channel]]: a rig of two to four cameras on the platform (docs/fusion.md).
void readChannels(const ConfigTable& root, const std::filesystem::path& configDir, Scenario& sc) {
    const std::vector<ConfigTable> chans = root.tableArray("channel");
    if (chans.empty()) return;
    if (root.contains("camera")) {
        throw SetupError(root.location("camera"),
                         "[camera] and [[channel]] exclude each other (give each channel its "
                         "preset)");
    }
    if (chans.size() < 2 || chans.size() > static_cast<std::size_t>(msg::kMaxChannels)) {
        throw SetupError(
            root.location("channel"),
            "a rig has 2 to " + std::to_string(msg::kMaxChannels) + " [[channel]] tables");
    }
    const ConfigTable s = root.table("scenario");
    for (const char* key : {"frame_rate_hz", "width", "height", "bits", "scan", "exposure_s"}) {
        if (s.contains(key)) s.fail(key, "with [[channel]], give it in each channel");
    }
    for (const ConfigTable& c : chans) {
        ChannelSpec ch;
        ch.loc = c.location();
        ch.name = c.require<std::string>("name");
        const bool nameOk = !ch.name.empty() && ch.name.size() <= 15 &&
                            ch.name.find_first_not_of(
                                "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnop"
                                "qrstuvwxyz0123456789_-") == std::string::npos;
        if (!nameOk) c.fail("name", "must be 1 to 15 characters of [A-Za-z0-9_-]");
        for (const ChannelSpec& o : sc.channels) {
            if (o.name == ch.name) c.fail("name", "two channels are named '" + ch.name + "'");
        }
        ch.format = readFormat(c, c, sc.seed + sc.channels.size(), configDir, ScenarioOverrides{});
        const auto arm = triple(c, "lever_arm_m", 100.0);
        const auto bore = triple(c, "boresight_deg", 90.0);
        ch.mount.leverArm_m = {arm[0], arm[1], arm[2]};
        ch.mount.yaw_rad = bore[0] * kRadPerDeg;
        ch.mount.pitch_rad = bore[1] * kRadPerDeg;
        ch.mount.roll_rad = bore[2] * kRadPerDeg;
        ch.faults.skew_s = finiteIn(c, "skew_s", 0.0, -0.1, 0.1);
        ch.faults.stampJitter_s = finiteIn(c, "stamp_jitter_s", 0.0, 0.0, 0.01);
        ch.faults.dropProbability = finiteIn(c, "drop_probability", 0.0, 0.0, 0.5);
        const auto mis = triple(c, "misregistration_deg", 10.0);
        for (int i = 0; i < 3; ++i)
            ch.faults.misregistration_rad[i] = mis[static_cast<std::size_t>(i)] * kRadPerDeg;
        sc.channels.push_back(ch);
    }
    applyFormat(sc.channels[0].format, sc);
    sc.channelIndex = 0;
}

// [scenario] and [camera] (or [[channel]]): names, seed, the format, start and duration.
void readScenarioTable(const ConfigTable& root, const std::filesystem::path& configDir,
                       const ScenarioOverrides& given, Scenario& sc) {
    const ConfigTable s = root.table("scenario");
    sc.name = s.require<std::string>("name");
    sc.description = s.get<std::string>("description", "");
    sc.group = s.get<std::string>("group", "");
    const std::int64_t scenarioSeed = s.get<std::int64_t>("seed", 1);
    if (scenarioSeed < 0) s.fail("seed", "must not be negative");
    sc.seed = static_cast<std::uint64_t>(scenarioSeed);
    if (root.contains("channel")) {
        if (!given.empty()) {
            throw SetupError(root.location("channel"),
                             "a rig names each channel's camera in its [[channel]]: --camera and "
                             "--set are for a scenario with one [camera]");
        }
        readChannels(root, configDir, sc);
    } else {
        const std::optional<ConfigTable> cam = root.optionalTable("camera");
        if (!cam && !given.empty()) {
            throw SetupError(sc.name +
                             ": --camera and --set need a [camera] table in the "
                             "scenario (a test pattern has no camera)");
        }
        applyFormat(readFormat(s, cam, sc.seed, configDir, given), sc);
    }
    sc.utcStart = s.get<std::string>("utc_start", sc.utcStart);
    if (!parseIso8601Utc(sc.utcStart, &sc.utcStart_unix_s)) {
        s.fail("utc_start", "not an ISO 8601 UTC instant such as 2024-01-25T17:54:00Z");
    }
    if (const auto d = s.optional<double>("duration_s")) {
        // Bounded so that the frame count ⌈d·rate⌉ is an exact 64-bit integer; a longer run
        // leaves duration_s out (a wall-clock run then goes on until it is stopped).
        if (!(*d > 0.0 && *d <= kMaxDuration_s)) {
            s.fail("duration_s", "must be in (0, " + std::to_string(kMaxDuration_s) +
                                     "] s (leave it out for a run that goes on until stopped)");
        }
        sc.duration_s = *d;
    }
}

// [platform]: the held pose and camera settings without telemetry.
void readPlatform(const ConfigTable& root, Scenario& sc) {
    const std::optional<ConfigTable> p = root.optionalTable("platform");
    // The same ranges as telemetry (rt/telemetry/track.h): a held pose is checked like one.
    const auto num = [&p](std::string_view key, double lo, double hi) {
        return p ? finiteIn(*p, key, 0.0, lo, hi) : 0.0;
    };
    sc.platform.lat_deg = num("lat_deg", -90.0, 90.0);
    sc.platform.lon_deg = num("lon_deg", -180.0, 360.0);
    sc.platform.alt_m = num("alt_m", -12000.0, 1.0e6);
    sc.platform.yaw_rad = num("yaw_deg", -360.0, 360.0) * kRadPerDeg;
    sc.platform.pitch_rad = num("pitch_deg", -360.0, 360.0) * kRadPerDeg;
    sc.platform.roll_rad = num("roll_deg", -360.0, 360.0) * kRadPerDeg;
    sc.platform.gain_V = num("gain_V", 0.0, 10000.0);
    sc.platform.gate_s = num("gate_s", 0.0, 1.0);
    sc.platform.agc = getOr<bool>(p, "agc", msg::kCommandedAgcDefault);
    if (!msg::gateModeFromValue(getOr<std::int64_t>(p, "gate_mode", 0), &sc.platform.gateMode)) {
        p->fail("gate_mode", "must be 0 (continuous), 1 (gated) or 2 (auto-gated)");
    }
    sc.platform.utc_unix_s = sc.utcStart_unix_s;
    // A [platform] that states a pose is rendered from it (rt/compose/platform_pose.h) until
    // telemetry gives another; without one, the scene's own camera.
    bool posed = false;
    for (const char* key : {"lat_deg", "lon_deg", "alt_m", "yaw_deg", "pitch_deg", "roll_deg"})
        posed = posed || (p && p->contains(key));
    sc.platform.poseFromTelemetry = posed;
}

// [runtime]: policies, threads, real-time scheduling, the external trigger.
void readRuntime(const ConfigTable& root, Scenario& sc) {
    const std::optional<ConfigTable> r = root.optionalTable("runtime");
    const std::string late = getOr<std::string>(r, "late_policy", "repeat");
    if (late != "repeat" && late != "drop")
        r->fail("late_policy", "must be \"repeat\" or \"drop\"");
    sc.latePolicy = late == "drop" ? LatePolicy::Drop : LatePolicy::Repeat;
    const std::string sinkErr = getOr<std::string>(r, "sink_errors", "count");
    if (sinkErr != "count" && sinkErr != "stop") {
        r->fail("sink_errors", "must be \"count\" or \"stop\"");
    }
    sc.sinkErrors = sinkErr == "stop" ? SinkErrorPolicy::Stop : SinkErrorPolicy::Count;
    const std::string bad = getOr<std::string>(r, "bad_input", "count");
    if (bad != "count" && bad != "stop") r->fail("bad_input", "must be \"count\" or \"stop\"");
    sc.badInputFatal = bad == "stop";
    sc.realtime = getOr<bool>(r, "realtime", false);
    sc.renderThreads = getOr<int>(r, "render_threads", 2);
    if (sc.renderThreads < 1 || sc.renderThreads > 16)
        r->fail("render_threads", "must be in [1, 16]");
    sc.cameraThreads = getOr<int>(r, "camera_threads", 1);
    if (sc.cameraThreads < 1 || sc.cameraThreads > 16)
        r->fail("camera_threads", "must be in [1, 16]");
    sc.renderCoarse = getOr<int>(r, "coarse_tiles", 1);
    if (sc.renderCoarse < 1 || sc.renderCoarse > 8) r->fail("coarse_tiles", "must be in [1, 8]");
    const std::string fieldRows = getOr<std::string>(r, "field_rows", "own");
    if (fieldRows != "all" && fieldRows != "own")
        r->fail("field_rows", "must be \"all\" or \"own\"");
    sc.fieldRowsOwn = fieldRows == "own";
    const std::string vis = getOr<std::string>(r, "primary_visibility", "embree");
    if (!render::parsePrimaryVisibility(vis, &sc.primaryVisibility)) {
        r->fail("primary_visibility", "must be \"embree\", \"gl\" or \"auto\"");
    }
    sc.staleAfter_s = getOr<double>(r, "stale_after_s", 0.5);
    sc.maxExtrapolation_s = getOr<double>(r, "max_extrapolation_s", 0.1);
    if (!(sc.staleAfter_s > 0.0 && sc.staleAfter_s <= kMaxDuration_s)) {
        r->fail("stale_after_s", "must be positive and finite");
    }
    if (!(sc.maxExtrapolation_s >= 0.0 && sc.maxExtrapolation_s <= kMaxDuration_s)) {
        r->fail("max_extrapolation_s", "must be finite and not negative");
    }
    // External trigger: gpio:CHIP:LINE, used with --clock wall (rt/loop: trigger clock).
    if (const auto trig = r ? r->optional<std::string>("trigger") : std::nullopt) {
        const std::string target = trig->rfind("gpio:", 0) == 0 ? trig->substr(5) : "";
        const auto colon = target.rfind(':');
        const bool lineOk = colon != std::string::npos && colon > 0 && colon + 1 < target.size() &&
                            target.find_first_not_of("0123456789", colon + 1) == std::string::npos;
        if (!lineOk) r->fail("trigger", "expected gpio:CHIP:LINE (e.g. gpio:gpiochip0:18)");
        sc.trigger = *trig;
    }
    sc.triggerTimeout_s = getOr<double>(r, "trigger_timeout_s", 0.0);
    if (!(sc.triggerTimeout_s >= 0.0 && sc.triggerTimeout_s <= 3600.0)) {
        r->fail("trigger_timeout_s", "must be in [0, 3600] s");
    }
}

// The frames: rendered from a scene, or the test pattern of one [[source]].
void readFrames(const ConfigTable& root, const std::string& file,
                const std::filesystem::path& configDir, Scenario& sc) {
    if (sc.rendered) {
        if (root.contains("source")) {
            throw SetupError(root.location("source"), "[[source]] and [scene] exclude each other");
        }
        if (!sc.camera.enabled) {
            throw SetupError(root.location("scene"),
                             "a rendered scenario needs a [camera] preset (or [[channel]])");
        }
        readSceneTables(root, file, configDir, sc.scene);
        sc.groundZ_m = finiteIn(root.table("scene"), "ground_z_m", 0.0, -1e4, 1e4);
        // A rig: each channel's camera; otherwise [camera].
        std::vector<std::pair<const CameraSpec*, FileLoc>> cams;
        for (const ChannelSpec& ch : sc.channels)
            cams.emplace_back(&ch.format.camera, ch.loc);
        if (cams.empty()) cams.emplace_back(&sc.camera, root.location("camera"));
        bool anyThermal = false;
        for (const auto& [cam, loc] : cams) {
            anyThermal = anyThermal || cam->thermal;
            if (cam->thermal && !sc.scene.thermal) {
                throw SetupError(loc,
                                 "a thermal camera preset needs a [thermal] table (weather, "
                                 "materials, focal_length_mm: docs/scenarios.md)");
            }
        }
        if (!anyThermal && sc.scene.thermal) {
            throw SetupError(sc.scene.thermal->loc, "[thermal] needs a thermal camera preset");
        }
        return;
    }
    const auto sources = root.tableArray("source");
    if (sources.size() != 1) {
        throw SetupError(FileLoc{file, 0, 0},
                         "exactly one [[source]] is needed (kind = \"test_pattern\"), or a "
                         "[scene]");
    }
    const ConfigTable src = sources[0];
    const std::string kind = src.require<std::string>("kind");
    if (kind != "test_pattern") src.fail("kind", "unknown source kind (known: test_pattern)");
    TestPatternSpec& tp = sc.testPattern;
    tp.radianceMax_W_m2_sr = src.get<double>("radiance_max_W_m2_sr", 1e-4);
    tp.fullScale_W_m2_sr = src.get<double>("full_scale_W_m2_sr", tp.radianceMax_W_m2_sr);
    tp.targetSpeed_px_s = src.get<double>("target_speed_px_s", 40.0);
    if (!(tp.radianceMax_W_m2_sr > 0.0 && std::isfinite(tp.radianceMax_W_m2_sr))) {
        src.fail("radiance_max_W_m2_sr", "must be positive and finite");
    }
    if (!(tp.fullScale_W_m2_sr > 0.0 && std::isfinite(tp.fullScale_W_m2_sr))) {
        src.fail("full_scale_W_m2_sr", "must be positive and finite");
    }
    if (!std::isfinite(tp.targetSpeed_px_s)) src.fail("target_speed_px_s", "must be finite");
}

// [telemetry]: recorded with the scenario; paths are relative to the scenario's folder.
void readTelemetry(const ConfigTable& root, const std::string& file, Scenario& sc) {
    const auto tel = root.optionalTable("telemetry");
    if (!tel) return;
    std::string spec = tel->require<std::string>("source");
    const auto colon = spec.find(':');
    const std::string scheme = colon == std::string::npos ? "" : spec.substr(0, colon);
    if (scheme != "replay" && scheme != "can" && scheme != "serial") {
        tel->fail("source", "expected replay:LOG, can:IFACE or serial:DEV");
    }
    if (scheme == "replay") {
        const auto q = spec.find('?');
        std::filesystem::path log =
            spec.substr(colon + 1, q == std::string::npos ? q : q - colon - 1);
        if (log.is_relative()) log = std::filesystem::path(file).parent_path() / log;
        if (!pathExists(log)) {
            tel->fail("source", "telemetry log not found: " + log.string());
        }
        spec = "replay:" + log.string() + (q == std::string::npos ? "" : spec.substr(q));
    }
    sc.telemetry = spec;
}

// [[event]]: the timeline, sorted by time.
void readEvents(const ConfigTable& root, Scenario& sc) {
    for (const ConfigTable& e : root.tableArray("event")) {
        TimelineEvent ev;
        ev.loc = e.location("t_s");
        ev.t_s = e.require<double>("t_s");
        if (!(ev.t_s >= 0.0 && ev.t_s <= kMaxDuration_s)) {
            e.fail("t_s", "must be in [0, " + std::to_string(kMaxDuration_s) + "] s");
        }
        if (sc.duration_s && ev.t_s > *sc.duration_s) {
            e.fail("t_s", "the event at " + std::to_string(ev.t_s) +
                              " s is after the end of the scenario (duration_s = " +
                              std::to_string(*sc.duration_s) + ")");
        }
        if (const auto lamp = e.optional<std::string>("lamp")) {
            if (!sc.rendered) e.fail("lamp", "lamps need a [scene]");
            ev.lamp = *lamp;
            ev.lampOn = e.get<bool>("on", true);
        } else if (e.contains("on")) {
            e.fail("on", "needs lamp = NAME");
        }
        ev.gain_V = e.optional<double>("gain_V");
        if (ev.gain_V && !(*ev.gain_V >= 0.0 && *ev.gain_V <= 10000.0))
            e.fail("gain_V", "must be in [0, 10000] V");
        ev.agc = e.optional<bool>("agc");
        ev.gate_s = e.optional<double>("gate_s");
        if (ev.gate_s && !(*ev.gate_s >= 0.0 && *ev.gate_s <= 1.0))
            e.fail("gate_s", "must be in [0, 1] s");
        if (const std::optional<std::int64_t> g = e.optional<std::int64_t>("gate_mode")) {
            msg::GateMode mode = msg::GateMode::Continuous;
            if (!msg::gateModeFromValue(*g, &mode)) e.fail("gate_mode", "must be 0, 1 or 2");
            ev.gateMode = mode;
        }
        if (!ev.lamp && !ev.gain_V && !ev.agc && !ev.gate_s && !ev.gateMode) {
            throw SetupError(
                ev.loc, "the event changes nothing (give lamp, gain_V, agc, gate_s or gate_mode)");
        }
        sc.events.push_back(ev);
    }
    std::stable_sort(sc.events.begin(), sc.events.end(),
                     [](const TimelineEvent& a, const TimelineEvent& b) { return a.t_s < b.t_s; });
}

Scenario fromDocument(const ConfigDocument& doc, const std::string& file,
                      const std::filesystem::path& configDir, const ScenarioOverrides& given) {
    Scenario sc;
    sc.file = file;
    const ConfigTable root = doc.root();
    sc.rendered = root.contains("scene");
    readScenarioTable(root, configDir, given, sc);
    readPlatform(root, sc);
    readRuntime(root, sc);
    readFrames(root, file, configDir, sc);
    readTelemetry(root, file, sc);
    readEvents(root, sc);
    doc.finish();
    return sc;
}

}  // namespace

Scenario channelScenario(const Scenario& rig, std::size_t i) {
    Scenario sc = rig;
    if (rig.channels.empty()) return sc;
    const ChannelSpec& ch = rig.channels.at(i);
    applyFormat(ch.format, sc);
    sc.channelIndex = static_cast<int>(i);
    return sc;
}

Scenario loadScenario(const std::filesystem::path& path, const std::filesystem::path& configDir,
                      const ScenarioOverrides& overrides) {
    std::filesystem::path file = path;
    if (isDirectory(path)) file = path / "scenario.toml";
    if (!pathExists(file)) {
        throw SetupError("scenario '" + path.string() + "': no such file");
    }
    const ConfigDocument doc = ConfigDocument::parseFile(file);
    return fromDocument(doc, file.string(), configDir, overrides);
}

Scenario parseScenario(const std::string& text, const std::string& name,
                       const std::filesystem::path& configDir, const ScenarioOverrides& overrides) {
    const ConfigDocument doc = ConfigDocument::parseString(text, name);
    return fromDocument(doc, name, configDir, overrides);
}

}  // namespace nvs::rt
