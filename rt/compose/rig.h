#pragma once
// The geometry of a camera rig (docs/fusion.md): channels mounted on one platform, each offset
// from the platform's camera by a lever arm and turned by boresight angles, and the published
// geometry a fusion consumer registers the channels with.
//
// Frames. The platform's camera body (rt/compose/platform_pose.h): x along the line of sight,
// y image right, z image down. A channel's mounting is given in those axes: its lever arm
// (metres) and its boresight as aerospace yaw, pitch, roll (sim/core/geometry.h nedFromBodyYpr,
// with the platform camera's body in place of NED), so that yaw turns the channel right, pitch
// up, roll clockwise as the image sees it.
//
// Ground-plane homography. For the scene's horizontal plane z = z0 (ENU), a point (x, y, z0)
// is at pixel u ~ K [r1 r2 (r3·z0 + t)] (x, y, 1)ᵀ in a camera with x_c = R·X + t (R's columns
// r1 r2 r3; msg::CameraGeometry). With G = K [r1 r2 r3·z0 + t] for each camera, the pixel of
// a plane point in camera B is H_AB · u_A with H_AB = G_B · G_A⁻¹ (Hartley & Zisserman, Multiple
// View Geometry, 2nd ed., §13.1), normalised to H[8] = 1. It is exact for points on the plane;
// a point at height h above it is displaced by the parallax of h over the baseline.

#include <cstdint>

#include "sim/core/geometry.h"
#include "sim/msg/frame.h"
#include "sim/render/renderer.h"
#include "sim/scene/scene.h"

namespace nvs::rt {

// The rig's shared trigger counter: every frame any channel starts (its first exposure's start)
// counted in one sequence, in order of time on the rig's time line (ties: the channel listed
// first), as a sync generator that fires each camera would count its pulses. Frame k of channel c
// starts at first_s[c] + k·period_s[c].
struct RigClock {
    int channels = 0;
    double period_s[msg::kMaxChannels] = {};
    double first_s[msg::kMaxChannels] = {};
    // The counter's value for frame k of channel c: the frames of every channel started before.
    std::int64_t count(int c, std::int64_t k) const noexcept;
};

struct Mount {
    Vec3 leverArm_m;  // platform camera body axes: forward, right, down
    double yaw_rad = 0.0, pitch_rad = 0.0, roll_rad = 0.0;
    bool identity() const noexcept {
        return leverArm_m == Vec3{} && yaw_rad == 0.0 && pitch_rad == 0.0 && roll_rad == 0.0;
    }
};

// The pose of a camera mounted by `m` on a camera at `base` (twist folded into the axes).
scene::CameraPose mountedPose(const scene::CameraPose& base, const Mount& m) noexcept;

// The pinhole and the scene-to-camera transform of a camera at `pose` (the axes as
// render::Renderer::setCamera derives them).
msg::CameraGeometry cameraGeometry(const scene::CameraPose& pose,
                                   const render::PinholeCamera& pin) noexcept;

// The same from the axes themselves (unit vectors: right, image up, forward).
msg::CameraGeometry cameraGeometry(const Vec3& position_m, const Vec3& right, const Vec3& up,
                                   const Vec3& forward, const render::PinholeCamera& pin) noexcept;

// H_AB of the plane z = z0_m, row-major, H[8] = 1; false when either camera sees the plane
// edge-on (or from within it) and no homography exists.
bool groundHomography(const msg::CameraGeometry& a, const msg::CameraGeometry& b, double z0_m,
                      double H[9]) noexcept;

}  // namespace nvs::rt
