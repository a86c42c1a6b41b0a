#pragma once
// The camera's pose in the scene from a platform state (sim/msg/platform.h): the one mapping the
// runtime's render stage (rt/render_stage) and a dataset's scenario stimulus
// (rt/compose/scene_stimulus.cpp) both use.
//
// The platform's position is placed in the scene's local ENU frame (origin at the scenario
// site) by the site's LocalTangentPlane (sim/core/geometry.h: WGS84 radii of curvature at the
// site; its error against the exact transformation is stated there).
// The camera's mounting: it looks along body x, image right = body y, image down = body z,
// the body turned by the aerospace yaw/pitch/roll of nedFromBody (sim/core/geometry.h).

#include "sim/astro/ephemeris.h"
#include "sim/core/geometry.h"
#include "sim/msg/platform.h"
#include "sim/scene/scene.h"

namespace nvs::rt {

class PlatformPose {
  public:
    PlatformPose() = default;
    explicit PlatformPose(const astro::Site& site) noexcept;

    // The scene-frame camera pose of a platform state. No allocation, no throw.
    scene::CameraPose poseFor(const msg::PlatformState& p) const noexcept;
    // A pose the renderer can take: every component finite and within 10⁸ m.
    static bool usable(const scene::CameraPose& pose) noexcept;

  private:
    LocalTangentPlane site_;
};

}  // namespace nvs::rt
