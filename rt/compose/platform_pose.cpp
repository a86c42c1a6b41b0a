#include "rt/compose/platform_pose.h"

#include <cmath>

#include "sim/core/geometry.h"
#include "sim/core/units.h"

namespace nvs::rt {
namespace {

// WGS84 (NIMA TR8350.2).
constexpr double kWgs84A_m = 6378137.0;
constexpr double kWgs84E2 = 6.69437999014e-3;

}  // namespace

PlatformPose::PlatformPose(const astro::Site& site) noexcept
    : lat0_rad_(site.lat_deg * kRadPerDeg),
      lon0_rad_(site.lon_deg * kRadPerDeg),
      h0_m_(site.height_m) {
    const double sl = std::sin(lat0_rad_);
    const double w = std::sqrt(1.0 - kWgs84E2 * sl * sl);
    primeVerticalRadius_m_ = kWgs84A_m / w;
    meridianRadius_m_ = kWgs84A_m * (1.0 - kWgs84E2) / (w * w * w);
}

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
    const double east = (p.lon_deg * kRadPerDeg - lon0_rad_) * (primeVerticalRadius_m_ + h0_m_) *
                        std::cos(lat0_rad_);
    const double north = (p.lat_deg * kRadPerDeg - lat0_rad_) * (meridianRadius_m_ + h0_m_);
    pose.position_m = {east, north, p.alt_m - h0_m_};
    const Mat3 enuFromBody = enuFromNed() * nedFromBodyYpr(p.yaw_rad, p.pitch_rad, p.roll_rad);
    const Vec3 forward_enu = enuFromBody * Vec3{1.0, 0.0, 0.0};
    pose.target_m = pose.position_m + forward_enu;
    pose.up = enuFromBody * Vec3{0.0, 0.0, -1.0};
    pose.twist_rad = 0.0;
    return pose;
}

}  // namespace nvs::rt
