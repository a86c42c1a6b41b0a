#pragma once
// The scenario file: the one loader every command uses (run, render, replay, bench), with one
// set of defaults. Strict TOML (sim/core/config.h): every key below is optional unless marked,
// and any other key is an error with its file:line and the nearest known key.
//
//   [scenario]                         name            string   required
//                                      description     string   ""
//                                      frame_rate_hz   Hz       60 (59.94, 29.97 exact NTSC);
//                                                      0.001..10000
//                                      width, height   px       320, 240
//                                      bits            1..16    8 (ADC depth of the counts)
//                                      exposure_s      s        one period
//                                      utc_start       ISO 8601 "2000-01-01T00:00:00Z"
//                                      duration_s      s        unbounded (frames = ⌈d·rate⌉);
//                                                      at most kMaxDuration_s (10⁷ s)
//                                      scan            "progressive" | "interlaced" (progressive):
//                                                      interlaced = frame_rate_hz frames woven
//                                                      from two fields at their own times
//   [platform]  held pose and camera   lat_deg lon_deg alt_m yaw_deg pitch_deg roll_deg
//               settings without       gain_V gate_s              (all 0)
//               telemetry              agc             bool      true
//                                      gate_mode       0 continuous | 1 gated | 2 auto   0
//   [runtime]                          late_policy     "repeat" | "drop"      "repeat"
//                                      sink_errors     "count" | "stop"       "count"
//                                      bad_input       "count" | "stop"       "count"
//                                      realtime        bool (SCHED_FIFO+mlockall) false
//                                      stale_after_s   s                      0.5
//                                      max_extrapolation_s s                  0.1
//                                      render_threads  1..16 (2), coarse_tiles 1..8 (1)
//                                      camera_threads  1..16 (1): the camera chain's rows
//                                                      split over this many threads (the
//                                                      same bits with any number)
//                                      field_rows      "own" | "all": an interlaced
//                                                      field renders only its own rows "own"
//                                      primary_visibility "embree" | "gl" | "auto" ("embree"):
//                                                      how the primary hits are found
//                                                      (docs/render.md)
//                                      trigger         "gpio:CHIP:LINE": with --clock wall,
//                                                      frames follow its rising edges
//                                      trigger_timeout_s s: no edge → stalled (3 periods)
//   [scenario] also: group (string), seed (integer ≥ 0, default 1: the noise seed)
//   [scene]     the frames are rendered (sim/render), and no [[source]]:
//                                      file            path     required (relative to the file)
//                                      lamps_on        array of lamp names (absent: each
//                                                      lamp's own `on`)
//               with it (docs/scene.md):
//   [site]                             lat_deg lon_deg height_m (0) pressure_hPa (1013.25)
//                                      temperature_C (15)
//   [atmosphere]                       visibility_km (23) aerosol ozone_DU (300)
//                                      precipitable_water_cm (1.5) cloud_optical_depth (0)
//                                      ground_albedo (0.15)
//   [telemetry] source = "replay:LOG" | "can:…" | "serial:…" (LOG relative to the scenario)
//   [[event]]   t_s (s, ≥ 0, ≤ duration_s) and any of: lamp = NAME with on = bool; gain_V;
//               agc (bool); gate_s; gate_mode (0..2)
//   [[source]]  exactly one without [scene], kind = "test_pattern" (rt/synth):
//                                      radiance_max_W_m2_sr   W/m²/sr   1e-4
//                                      full_scale_W_m2_sr     W/m²/sr   radiance_max
//                                      target_speed_px_s      px/s      40
//   [camera]    optional: the IICCD    preset          string   required (config/cameras/NAME
//               model (sim/sensor)                              or a path to a .toml)
//               instead of the linear  set             array of "KEY=VALUE" preset overrides
//               test camera            spectrum        flat | blackbody:T | moon | night_sky
//                                                      ("flat"): source shape for W/m²/sr → pe
//                                      seed            integer ≥ 0 (1)
//                                      controls        "platform" | "preset" ("platform"):
//                                                      gain_V/agc/gate from the platform state
//               With [camera], width, height and bits default to the preset's (when given in
//               [scenario] they override it), and frame_rate_hz defaults to the preset's field
//               rate (scan = "field") or frame rate (scan = "frame", or an interlaced
//               scenario); the camera is driven at the scenario's rate, or at twice it when
//               interlaced (one call per field; interlaced needs a field-scan preset).
//   [[channel]] a camera rig instead of [camera] (docs/fusion.md): two to four channels on one
//               time line, each with the keys of [camera] and
//                                      name            string   required, [A-Za-z0-9_-]{1,15}
//                                      frame_rate_hz width height bits scan exposure_s: as in
//                                                      [scenario] (defaults: the preset's)
//                                      lever_arm_m     [fwd, right, down] m from the platform's
//                                                      camera (|·| ≤ 100 m)       [0, 0, 0]
//                                      boresight_deg   [yaw, pitch, roll] (±90°)  [0, 0, 0]
//                                      skew_s          exposures this much late (±0.1 s)  0
//                                      stamp_jitter_s  rms noise on the stamps (≤ 0.01 s) 0
//                                      drop_probability frames never sent (≤ 0.5)         0
//                                      misregistration_deg [yaw, pitch, roll] of the true
//                                                      boresight against the published (±10°)
//               [scene] ground_z_m: the plane of the published homographies (0)

#include <cstdint>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "rt/clock/clock.h"
#include "rt/compose/rig.h"
#include "rt/loop/frame_loop.h"
#include "rt/loop/stages.h"
#include "sim/astro/ephemeris.h"
#include "sim/bolometer/camera.h"
#include "sim/render/renderer.h"
#include "sim/sensor/camera.h"
#include "sim/sky/atmosphere.h"
#include "sim/thermal/heat_balance.h"

namespace nvs::rt {

// Longest duration_s (and latest event t_s), about 116 days: ⌈duration·rate⌉ frames stay
// an exact 64-bit count at the highest rate (10⁷ s · 10⁴ Hz = 10¹¹).
inline constexpr double kMaxDuration_s = 1.0e7;

struct TestPatternSpec {
    double radianceMax_W_m2_sr = 1e-4;
    double fullScale_W_m2_sr = 1e-4;
    double targetSpeed_px_s = 40.0;
};

// The [camera] table: the preset loaded, validated and set to the loop's size and rate.
struct CameraSpec {
    bool enabled = false;
    sensor::CameraParams params;
    // A thermal preset (config/thermal_cameras/PRESET.toml): the uncooled microbolometer
    // (sim/bolometer) instead of the intensified camera; `params` then carries only the format
    // (size, frame scan and rate, depth) the loop runs at.
    bool thermal = false;
    std::optional<bolometer::ThermalCameraParams> thermalParams;
    // The preset and its [camera] set overrides as given, without the scenario's size, depth
    // and rate: the sensor as designed, whose field of view the renderer keeps.
    std::string preset;
    sensor::Overrides presetOverrides;
    std::string spectrum = "flat";
    std::uint64_t seed = 1;
    bool controlsFromPlatform = true;
};

// One scripted event of the [[event]] timeline: at run time t_s (seconds from the start) the
// named lamp is switched, or the camera controls change; it holds until a later event.
struct TimelineEvent {
    double t_s = 0.0;
    FileLoc loc;                      // the event's place in the file, for errors
    std::optional<std::string> lamp;  // a lamp of the scene, by name
    bool lampOn = true;
    std::optional<double> gain_V;
    std::optional<bool> agc;
    std::optional<double> gate_s;
    std::optional<msg::GateMode> gateMode;
};

// [site], [atmosphere] and [scene]: what the renderer's composition needs (rt/compose).
// [thermal]: what a thermal camera's scene needs besides the visible one (docs/thermal.md).
struct ThermalSpec {
    std::filesystem::path weatherFile;    // absolute
    std::filesystem::path materialsFile;  // absolute; default config/thermal/materials.toml
    double focalLength_mm = 18.0;         // the lens
    thermal::HeatBalanceParams heat;      // linke_turbidity, dt_s (thermal::readHeatBalanceParams)
    FileLoc loc;                          // the [thermal] table
};

// One [[channel]] of a rig: its camera and format, its mounting, and the faults injected.
struct ChannelFaults {
    double skew_s = 0.0;
    double stampJitter_s = 0.0;  // rms
    double dropProbability = 0.0;
    double misregistration_rad[3] = {};  // yaw, pitch, roll
    bool any() const noexcept {
        return skew_s != 0.0 || stampJitter_s != 0.0 || dropProbability != 0.0 ||
               misregistration_rad[0] != 0.0 || misregistration_rad[1] != 0.0 ||
               misregistration_rad[2] != 0.0;
    }
};
// The frames a camera makes: its camera and the format the loop runs it at (a scenario's, or a
// rig channel's).
struct FrameFormat {
    CameraSpec camera;
    FrameRate rate;
    ScanKind scan = ScanKind::Progressive;
    int width = 320, height = 240, bits = 8;
    double exposure_s = 0.0;
};
struct ChannelSpec {
    std::string name;
    FileLoc loc;
    FrameFormat format;
    Mount mount;
    ChannelFaults faults;
};

struct SceneSpec {
    std::optional<ThermalSpec> thermal;  // with a thermal camera preset
    astro::Site site;
    sky::AtmosphereParams atmosphere;
    // [atmosphere] lunar_sky_scale: the Moon's light scattered by the atmosphere, 1 as the
    // physics has it, 0 without it (sky::frameSky).
    double lunarSkyScale = 1.0;
    std::filesystem::path sceneFile;                  // absolute
    std::optional<std::vector<std::string>> lampsOn;  // absent: each lamp's own `on`
};

struct Scenario {
    std::string file;
    std::string name;
    std::string description;
    std::string group;       // e.g. "thesis", "tracking", "airborne"
    std::uint64_t seed = 1;  // noise seed (the camera's unless [camera] seed is given)
    // The scenario has a [scene] table: frames are rendered from it (sim/render) instead of
    // the test pattern; its [site], [atmosphere] and [scene] tables are read by sim/scene.
    bool rendered = false;
    // [telemetry] source: an --telemetry spec, file paths resolved against the scenario's
    // folder; --telemetry on the command line takes precedence.
    std::optional<std::string> telemetry;
    std::vector<TimelineEvent> events;  // sorted by t_s
    int renderThreads = 2;     // [runtime] render_threads: rows split over this many threads
    int cameraThreads = 1;     // [runtime] camera_threads: the camera chain's rows, likewise
    int renderCoarse = 1;      // [runtime] coarse_tiles: lighting every N-th pixel (1 = full rate)
    bool fieldRowsOwn = true;  // [runtime] field_rows = "own" (FrameLoopConfig::fieldRowsOnly)
    // [runtime] primary_visibility: Embree's primary rays, OpenGL rasterisation, or the faster
    // of the two present (Renderer::choosePrimaryVisibility).
    render::PrimaryVisibility primaryVisibility = render::PrimaryVisibility::kEmbree;
    FrameRate rate;  // of the emitted frames
    ScanKind scan = ScanKind::Progressive;
    std::optional<std::string> trigger;  // [runtime] trigger, "gpio:CHIP:LINE"
    double triggerTimeout_s = 0.0;       // 0: three periods
    int width = 320;
    int height = 240;
    int bits = 8;
    double exposure_s = 0.0;
    std::string utcStart = "2000-01-01T00:00:00Z";
    double utcStart_unix_s = 946684800.0;  // the same instant
    std::optional<double> duration_s;
    PlatformState platform;
    LatePolicy latePolicy = LatePolicy::Repeat;
    SinkErrorPolicy sinkErrors = SinkErrorPolicy::Count;
    bool badInputFatal = false;
    bool realtime = false;
    double staleAfter_s = 0.5;
    double maxExtrapolation_s = 0.1;
    TestPatternSpec testPattern;
    CameraSpec camera;
    SceneSpec scene;  // rendered scenarios
    // A rig ([[channel]]): its channels; `camera` and the format above are the first one's.
    std::vector<ChannelSpec> channels;
    int channelIndex = -1;   // channelScenario(i): i
    double groundZ_m = 0.0;  // [scene] ground_z_m

    // How the emitted frames' rows were exposed (interlaced: the camera's field order; top
    // field first without a camera).
    msg::FieldOrder fieldOrder() const {
        if (scan != ScanKind::Interlaced) return msg::FieldOrder::Progressive;
        return !camera.enabled || camera.params.topFieldFirst ? msg::FieldOrder::TopFirst
                                                              : msg::FieldOrder::BottomFirst;
    }
};

// Channel i of a rig as a scenario of its own: the rig's, with the channel's camera, format
// and seed (channelIndex = i; the channels kept, for the peers' mountings).
Scenario channelScenario(const Scenario& rig, std::size_t i);

// The command line's changes to a scenario's camera (nvstim run/render --camera, --set; the
// GStreamer source's and the Python module's the same): another preset in place of [camera]
// preset, and KEY=VALUE settings of the preset that win over [camera] set. A rig's channels
// each name their own camera, so a rig takes neither.
struct ScenarioOverrides {
    std::optional<std::string> cameraPreset;
    sensor::Overrides cameraSets;
    bool empty() const { return !cameraPreset && cameraSets.empty(); }
};

// Reads a scenario TOML file (or SCENARIO/scenario.toml for a folder); camera presets and
// spectra from configDir. Throws SetupError.
Scenario loadScenario(const std::filesystem::path& path, const std::filesystem::path& configDir,
                      const ScenarioOverrides& overrides = {});
Scenario parseScenario(const std::string& text, const std::string& name,
                       const std::filesystem::path& configDir,
                       const ScenarioOverrides& overrides = {});

// "2024-01-25T17:54:00Z" (fractional seconds and a +hh:mm offset accepted) → Unix seconds.
// Returns false when malformed.
bool parseIso8601Utc(const std::string& text, double* unix_s);

}  // namespace nvs::rt
