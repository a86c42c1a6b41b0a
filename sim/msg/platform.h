#pragma once
// The platform state as commanded (docs/style.md §5): where the platform (the vehicle carrying the
// camera) is, how it is turned, and how the camera is told to be set, at one instant. Filled
// by the runtime's platform source from telemetry (CAN, serial, a recorded log) or from the
// scenario ([platform] values held, [[event]] timeline). What the camera actually applied is
// another message (FieldMeta, frame.h): with AGC on, the camera chooses its own gain.
//
// Every time is on the run clock: seconds since the run started (the sim clock and the wall
// clock use the same axis).

#include <cstdint>

namespace nvs::msg {

// The photocathode gate as commanded (docs/sensor.md, "Controls"). The numbers are the wire and
// scenario values (`gate_mode`, the DBC signal): 0, 1, 2.
enum class GateMode : std::int32_t {
    Continuous = 0,  // the photocathode on for the whole field
    Gated = 1,       // on for gate_s (or the preset's gate)
    AutoGated =
        2,  // the camera shortens the gate in bright light (a preset whose loop is autogate)
};

// A gate mode from its wire or scenario value; false (and *mode untouched) outside 0..2.
inline bool gateModeFromValue(std::int64_t v, GateMode* mode) noexcept {
    if (v < 0 || v > 2) return false;
    *mode = static_cast<GateMode>(v);
    return true;
}

// The one default of the commanded AGC switch: the platform state, the scenario's [platform]
// `agc`, a telemetry update and the camera command all start from it.
inline constexpr bool kCommandedAgcDefault = true;

struct PlatformState {
    double t_sample_s = 0.0;  // instant this state describes (run clock) [s]
    // Position: WGS84 geodetic latitude and longitude [deg], height above the ellipsoid [m].
    double lat_deg = 0.0;
    double lon_deg = 0.0;
    double alt_m = 0.0;
    // Attitude: the aerospace yaw-pitch-roll of nedFromBody (sim/core/geometry.h) [rad]; yaw
    // is the heading from north through east, the camera looks along body x.
    double yaw_rad = 0.0;
    double pitch_rad = 0.0;
    double roll_rad = 0.0;
    // UTC of t_sample_s as Unix seconds: from telemetry time, else the scenario start + t.
    double utc_unix_s = 0.0;
    // Camera commands (telemetry or the scenario). gain_V: MCP control voltage commanded [V],
    // used when agc is off. gate_s: photocathode gate width commanded [s] (0: the preset's).
    double gain_V = 0.0;
    double gate_s = 0.0;
    GateMode gateMode = GateMode::Continuous;  // commanded gate mode
    bool agc = kCommandedAgcDefault;           // commanded: the camera's automatic gain control on
    std::uint32_t lampMask = 0;                // bit i: lamp i of the scene switched on
    // The pose above is rendered: telemetry gave it, or the scenario's [platform] states one
    // (held until telemetry gives another). false: the scene's own camera.
    bool poseFromTelemetry = false;
    bool stale = false;           // the newest telemetry is older than the stale limit
    double telemetryRx_s = -1.0;  // receive time of the newest sample used (run clock); <0 none
};

}  // namespace nvs::msg
