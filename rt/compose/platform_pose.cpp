#include "rt/compose/platform_pose.h"

#include <cmath>

#include "sim/core/geometry.h"
#include "sim/core/units.h"

namespace nvs::rt {

PlatformPose::PlatformPose(const astro::Site& site) noexcept
    : site_(site.lat_deg, site.lon_deg, site.height_m) {}

bool PlatformPose::usable(const scene::CameraPose& pose) noexcept {
    // Finite, and within 10⁸ m of the scene origin: beyond that the ray arithmetic in single
    // precision loses the scene entirely (and the telemetry bounds allow 10⁶ m of altitude).
    constexpr double kMaxDistance_m = 1e8;
    for (const Vec3& v : {pose.position_m, pose.target_m, pose.up}) {
        for (const double c : {v.x, v.y, v.z}) {
            if (!(std::fabs(c) <= kMaxDistance_m)) return false;
        }
    }
    return true;
}

scene::CameraPose PlatformPose::poseFor(const msg::PlatformState& p) const noexcept {
    scene::CameraPose pose;
    pose.position_m = site_.enuFrom(p.lat_deg, p.lon_deg, p.alt_m);
    const Mat3 enuFromBody = enuFromNed() * nedFromBodyYpr(p.yaw_rad, p.pitch_rad, p.roll_rad);
    const Vec3 forward_enu = enuFromBody * Vec3{1.0, 0.0, 0.0};
    pose.target_m = pose.position_m + forward_enu;
    pose.up = enuFromBody * Vec3{0.0, 0.0, -1.0};
    pose.twist_rad = 0.0;
    return pose;
}

}  // namespace nvs::rt
