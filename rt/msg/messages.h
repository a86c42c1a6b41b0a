#pragma once
// Typed messages between runtime stages (STYLE §5). Plain structs, fixed size, no owning
// pointers: a stage consumes one and fills another; nothing is allocated per frame. Every
// message carries the time it describes, `t_sample_s`, on the run's clock (seconds since the
// run started; the sim clock and the wall clock use the same axis).

#include <cstdint>

namespace nvs::rt {

// Where the platform (vehicle carrying the camera) is, how it is turned, and how the camera is
// set, at one instant. Angles are the aerospace yaw-pitch-roll of nedFromBody (geometry.h).
struct PlatformState {
    double t_sample_s = 0.0;  // instant this state describes (run clock)
    double lat_deg = 0.0;
    double lon_deg = 0.0;
    double alt_m = 0.0;    // height above the ellipsoid
    double yaw_rad = 0.0;  // heading, from north through east
    double pitch_rad = 0.0;
    double roll_rad = 0.0;
    double utc_unix_s = 0.0;     // UTC of t_sample_s (from telemetry time, else scenario start + t)
    double gain_V = 0.0;         // MCP control voltage commanded by telemetry
    double gate_s = 0.0;         // photocathode gate width
    std::int32_t gateMode = 0;   // 0 continuous, 1 gated, 2 auto-gated
    bool agc = true;             // camera's automatic gain control on
    std::uint32_t lampMask = 0;  // bit i: lamp i switched on
    bool poseFromTelemetry = false;  // false: scenario's initial pose held
    bool stale = false;              // newest telemetry older than the stale limit
    double telemetryRx_s = -1.0;     // receive time of the newest sample used (run clock); <0 none
};

// A tagged object's bounding box in output pixel coordinates (ground truth for the equipment
// under test's detector).
struct TruthBox {
    std::int32_t id = 0;
    float x_px = 0.0f, y_px = 0.0f, w_px = 0.0f, h_px = 0.0f;
};
inline constexpr int kMaxTruthBoxes = 16;

// Request to render and expose one frame.
struct FrameRequest {
    std::int64_t frame = 0;   // frame index k
    double t_sample_s = 0.0;  // exposure mid-time t0 + k·dt (+ dt/2 of the exposure)
    double exposure_s = 0.0;  // integration time
    PlatformState platform;   // pose and camera settings at t_sample_s
};

// One exposure of a frame: the whole frame (progressive scan) or one field (interlaced scan).
struct FieldMeta {
    double t_sample_s = 0.0;  // exposure mid-time (run clock)
    double gain_V = 0.0;      // applied by the camera stage (or commanded, linear camera)
    double gate_s = 0.0;      // applied gate (0: continuous)
};
inline constexpr int kMaxFields = 2;

// What a frame carries besides its pixels (the JSON-lines metadata record, DESIGN §6).
// Interlaced scan (rt/loop/frame_loop.h): a frame is woven from two fields, field 0 on the even
// rows, exposed one field period before field 1 on the odd rows. The frame-level fields
// (t_sample_s, platform, truth) are those of field 1, the field that completes the frame;
// `field[f]` holds each field's own exposure. Progressive scan: fieldCount = 1 and field[0]
// repeats the frame's.
struct FrameMeta {
    std::int64_t frame = 0;
    double t_sample_s = 0.0;
    double exposure_s = 0.0;  // of one exposure (a field when interlaced)
    PlatformState platform;
    std::int32_t truthCount = 0;
    TruthBox truth[kMaxTruthBoxes];
    std::int32_t fieldCount = 1;
    FieldMeta field[kMaxFields];
    // Trigger clock: CLOCK_MONOTONIC time of the rising edge that started the exposure (0 else).
    std::int64_t triggerEdge_ns = 0;
};

}  // namespace nvs::rt
