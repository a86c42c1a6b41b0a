#pragma once
// Per-frame messages between the runtime's stages and its sinks (docs/style.md §5). Plain structs,
// fixed size, no owning pointers: a stage consumes one and fills another; nothing is allocated
// per frame. Every time is on the run clock (seconds since the run started).

#include <cstdint>

#include "sim/core/image.h"
#include "sim/msg/platform.h"

namespace nvs::msg {

// A tagged object's bounding box in output pixel coordinates (ground truth for the equipment
// under test's detector), with what a tracker's scoring needs beside it.
struct TruthBox {
    std::int32_t id = 0;
    float x_px = 0.0f, y_px = 0.0f, w_px = 0.0f, h_px = 0.0f;  // clipped to the image
    float visible = 1.0f;    // fraction of its projected area seen, not hidden by other objects
    float range_m = 0.0f;    // camera to the object (its centroid); 0: not known
    bool truncated = false;  // the image's edge (or the camera plane) cuts its projection
    char cls[16] = {};       // its class, NUL-terminated (empty: none)
};
inline constexpr int kMaxTruthBoxes = 16;

// The camera's geometry at an exposure (a rendered scene; `valid` false for a test pattern), as a
// pinhole in OpenCV's axes: a scene point X (ENU metres, the scene's frame) is at camera point
// x_c = R·X + t (x right, y down, z forward along the optical axis) and at pixel
// (fx·x_c/z_c + cx, fy·y_c/z_c + cy), (0, 0) being the image's top-left corner (pixel centres at
// +0.5, as the truth boxes), so cx = width/2, cy = height/2.
struct CameraGeometry {
    bool valid = false;
    std::int32_t width = 0, height = 0;
    double fx_px = 0.0, fy_px = 0.0, cx_px = 0.0, cy_px = 0.0;
    double R[9] = {};  // row-major: rows are the camera's x, y, z axes in the scene frame
    double t_m[3] = {};
};

// A channel of a camera rig (rt/compose/rig.h, docs/fusion.md): which channel made the frame, the
// homography of the ground plane from its pixels to every channel's (as published: the declared
// mountings), and the faults injected into it, the truth a consumer is measured against.
inline constexpr int kMaxChannels = 4;
struct RigMeta {
    std::int32_t channel = -1;         // its index in the scenario; −1: not a rig
    std::int32_t channels = 0;         // channels in the rig
    char name[kMaxChannels][16] = {};  // each channel's name, NUL-terminated
    double groundZ_m = 0.0;            // the plane of the homographies: z = groundZ_m (ENU)
    // H[j]: this channel's pixel → channel j's, at t_sample_s (row-major, H[j][8] = 1; own
    // index: identity); valid[j] false where the plane is seen edge-on.
    double H[kMaxChannels][9] = {};
    bool valid[kMaxChannels] = {};
    std::int64_t triggerCount = 0;  // the rig's shared counter of frames started (RigClock)
    // Faults (docs/fusion.md, "Faults on demand"):
    double skew_s = 0.0;                 // every exposure of the channel this much late
    double stampJitter_s = 0.0;          // this frame's stamps minus its true times
    std::int64_t droppedBefore = 0;      // frames dropped since the one emitted before
    double misregistration_rad[3] = {};  // yaw, pitch, roll of the true boresight against
                                         // the published one
};

// Request to render and expose one frame (or one field of an interlaced frame).
struct FrameRequest {
    std::int64_t frame = 0;   // frame index k
    double t_sample_s = 0.0;  // exposure mid-time [s]
    double exposure_s = 0.0;  // integration time [s]
    PlatformState platform;   // pose and camera commands at t_sample_s
    // Rows the render must fill: −1 every row; 0 or 1 only the rows y with y mod 2 = rowParity
    // (an interlaced field's own rows; the others may hold the previous field's radiance).
    int rowParity = -1;
};

// The radiance at the lens of one frame, each image in its own unit. Either may be empty: a
// stage fills what it produces (RenderStage::Outputs, rt/loop/stages.h).
//   lpe_pe_s_m2_sr  photoelectron radiance Lpe [pe s⁻¹ m⁻² sr⁻¹] in the camera's band: what
//                   the camera chain consumes (the scene renderer's output).
//   band_W_m2_sr    band-integrated radiance L [W m⁻² sr⁻¹] (the scene renderer's second
//                   output; the test pattern's only one, which a camera converts to Lpe with
//                   its own k = peRadiancePerBandRadiance, sim/sensor/camera.h).
template <typename T>
struct RadianceImages {
    ImageView<T> lpe_pe_s_m2_sr;
    ImageView<T> band_W_m2_sr;
};
using RadianceFrame = RadianceImages<const float>;  // to read (camera, sinks)
using RadianceTarget = RadianceImages<float>;       // to fill (render)

// What the camera applied to one exposure: the whole frame (progressive scan) or one field
// (interlaced scan). The camera stage's result (CameraStage::expose, rt/loop/stages.h).
struct FieldMeta {
    double t_sample_s = 0.0;  // exposure mid-time [s]
    double gain_V = 0.0;      // MCP control voltage applied (a linear camera: as commanded) [V]
    double gate_s = 0.0;      // photocathode gate applied [s] (0: continuous)
    // The truth and the camera's geometry at this exposure's instant (an interlaced frame's
    // fields are a field apart).
    std::int32_t truthCount = 0;
    TruthBox truth[kMaxTruthBoxes];
    CameraGeometry camera;
};
inline constexpr int kMaxFields = 2;

// What a frame carries besides its pixels (the JSON-lines metadata record, docs/design.md §6).
// Interlaced scan (rt/loop/frame_loop.h): a frame is woven from two fields, field 0 on the even
// rows, exposed one field period before field 1 on the odd rows. The frame-level fields
// (t_sample_s, platform, truth) are those of field 1, the field that completes the frame;
// `field[f]` holds what the camera applied to each field, and each field's own truth. Progressive
// scan: fieldCount = 1 and field[0] is the frame's.
struct FrameMeta {
    std::int64_t frame = 0;
    double t_sample_s = 0.0;  // exposure mid-time [s]
    double exposure_s = 0.0;  // of one exposure (a field when interlaced) [s]
    PlatformState platform;   // as commanded
    std::int32_t truthCount = 0;
    TruthBox truth[kMaxTruthBoxes];
    CameraGeometry camera;  // at t_sample_s (the render stage's; invalid for a test pattern)
    std::int32_t fieldCount = 1;
    FieldMeta field[kMaxFields];  // as applied, per exposure
    // Trigger clock: CLOCK_MONOTONIC time of the rising edge that started the exposure (0 else).
    std::int64_t triggerEdge_ns = 0;
    RigMeta rig;  // a channel of a rig (rig.channel ≥ 0)

    // What the camera applied to the exposure that completes the frame.
    const FieldMeta& applied() const {
        return field[fieldCount >= kMaxFields ? kMaxFields - 1 : 0];
    }
};

}  // namespace nvs::msg
