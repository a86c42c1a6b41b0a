#include "sim/core/geometry.h"

#include "sim/core/units.h"

namespace nvs {

Mat3 rotationX(double a) {
    const double c = std::cos(a), s = std::sin(a);
    return Mat3::fromRows({1, 0, 0}, {0, c, -s}, {0, s, c});
}
Mat3 rotationY(double a) {
    const double c = std::cos(a), s = std::sin(a);
    return Mat3::fromRows({c, 0, s}, {0, 1, 0}, {-s, 0, c});
}
Mat3 rotationZ(double a) {
    const double c = std::cos(a), s = std::sin(a);
    return Mat3::fromRows({c, -s, 0}, {s, c, 0}, {0, 0, 1});
}

Mat3 nedFromBodyYpr(double yaw_rad, double pitch_rad, double roll_rad) {
    return rotationZ(yaw_rad) * rotationY(pitch_rad) * rotationX(roll_rad);
}

void yprFromNedFromBody(const Mat3& r, double* yaw_rad, double* pitch_rad, double* roll_rad) {
    // r = Rz(ψ)Ry(θ)Rx(φ): r[2][0] = −sin θ, r[1][0]/r[0][0] = tan ψ, r[2][1]/r[2][2] = tan φ.
    const double s = -r.m[2][0];
    *pitch_rad = std::asin(s > 1.0 ? 1.0 : (s < -1.0 ? -1.0 : s));
    *yaw_rad = std::atan2(r.m[1][0], r.m[0][0]);
    *roll_rad = std::atan2(r.m[2][1], r.m[2][2]);
}

Vec3 enuFromAzAlt(double az_rad, double alt_rad) {
    const double ca = std::cos(alt_rad);
    return {ca * std::sin(az_rad), ca * std::cos(az_rad), std::sin(alt_rad)};
}

void azAltFromEnu(const Vec3& v, double* az_rad, double* alt_rad) {
    const double horiz = std::hypot(v.x, v.y);
    *alt_rad = std::atan2(v.z, horiz);
    double az = std::atan2(v.x, v.y);
    if (az < 0.0) az += kTwoPi;
    *az_rad = az;
}

namespace {
constexpr double kWgs84A_m = 6378137.0;
constexpr double kWgs84E2 = 6.69437999014e-3;
}  // namespace

LocalTangentPlane::LocalTangentPlane(double lat_deg, double lon_deg, double height_m) noexcept
    : lat0_rad_(lat_deg * kRadPerDeg), lon0_rad_(lon_deg * kRadPerDeg), h0_m_(height_m) {
    const double sl = std::sin(lat0_rad_);
    const double w = std::sqrt(1.0 - kWgs84E2 * sl * sl);
    primeVerticalRadius_m_ = kWgs84A_m / w;
    meridianRadius_m_ = kWgs84A_m * (1.0 - kWgs84E2) / (w * w * w);
}

Vec3 LocalTangentPlane::enuFrom(double lat_deg, double lon_deg, double height_m) const noexcept {
    const double east =
        (lon_deg * kRadPerDeg - lon0_rad_) * (primeVerticalRadius_m_ + h0_m_) * std::cos(lat0_rad_);
    const double north = (lat_deg * kRadPerDeg - lat0_rad_) * (meridianRadius_m_ + h0_m_);
    return {east, north, height_m - h0_m_};
}

}  // namespace nvs
