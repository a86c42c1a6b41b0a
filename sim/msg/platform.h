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
    std::int32_t gateMode = 0;   // commanded gate mode: 0 continuous, 1 gated, 2 auto-gated
    bool agc = true;             // commanded: the camera's automatic gain control on
    std::uint32_t lampMask = 0;  // bit i: lamp i of the scene switched on
    // The pose above is rendered: telemetry gave it, or the scenario's [platform] states one
    // (held until telemetry gives another). false: the scene's own camera.
    bool poseFromTelemetry = false;
    bool stale = false;           // the newest telemetry is older than the stale limit
    double telemetryRx_s = -1.0;  // receive time of the newest sample used (run clock); <0 none
};

}  // namespace nvs::msg
