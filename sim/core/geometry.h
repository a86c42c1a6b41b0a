#pragma once
// Small vector and rotation math. Frames go in names (docs/design.md §3): a rotation that takes
// body coordinates to ENU coordinates is `enuFromBody`, and `enuFromBody * v_body` is `v_enu`;
// chains read right to left: cameraFromEnu = cameraFromBody * bodyFromEnu.
//
// Frames used in nvstim:
//   ENU  local east-north-up at the site (z up);  NED  north-east-down;
//   body x forward, y right, z down (aerospace);  azimuth from north through east.

#include <cmath>

namespace nvs {

struct Vec3 {
    double x = 0.0, y = 0.0, z = 0.0;

    constexpr Vec3 operator+(const Vec3& o) const { return {x + o.x, y + o.y, z + o.z}; }
    constexpr Vec3 operator-(const Vec3& o) const { return {x - o.x, y - o.y, z - o.z}; }
    constexpr Vec3 operator-() const { return {-x, -y, -z}; }
    constexpr Vec3 operator*(double k) const { return {x * k, y * k, z * k}; }
    constexpr Vec3 operator/(double k) const { return {x / k, y / k, z / k}; }
    friend constexpr Vec3 operator*(double k, const Vec3& v) { return v * k; }
    constexpr bool operator==(const Vec3&) const = default;
};

constexpr double dot(const Vec3& a, const Vec3& b) {
    return a.x * b.x + a.y * b.y + a.z * b.z;
}
constexpr Vec3 cross(const Vec3& a, const Vec3& b) {
    return {a.y * b.z - a.z * b.y, a.z * b.x - a.x * b.z, a.x * b.y - a.y * b.x};
}
inline double norm(const Vec3& v) {
    return std::sqrt(dot(v, v));
}
inline Vec3 normalized(const Vec3& v) {
    return v / norm(v);
}

// A 3×3 matrix, row-major; used for rotations (orthonormal, det +1).
struct Mat3 {
    double m[3][3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};

    static constexpr Mat3 identity() { return Mat3{}; }
    static constexpr Mat3 fromRows(const Vec3& r0, const Vec3& r1, const Vec3& r2) {
        Mat3 a;
        a.m[0][0] = r0.x, a.m[0][1] = r0.y, a.m[0][2] = r0.z;
        a.m[1][0] = r1.x, a.m[1][1] = r1.y, a.m[1][2] = r1.z;
        a.m[2][0] = r2.x, a.m[2][1] = r2.y, a.m[2][2] = r2.z;
        return a;
    }
    constexpr Vec3 operator*(const Vec3& v) const {
        return {m[0][0] * v.x + m[0][1] * v.y + m[0][2] * v.z,
                m[1][0] * v.x + m[1][1] * v.y + m[1][2] * v.z,
                m[2][0] * v.x + m[2][1] * v.y + m[2][2] * v.z};
    }
    constexpr Mat3 operator*(const Mat3& b) const {
        Mat3 c;
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                c.m[i][j] = m[i][0] * b.m[0][j] + m[i][1] * b.m[1][j] + m[i][2] * b.m[2][j];
            }
        }
        return c;
    }
    constexpr Mat3 transposed() const {
        Mat3 t;
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j)
                t.m[i][j] = m[j][i];
        }
        return t;
    }
    constexpr double det() const {
        return m[0][0] * (m[1][1] * m[2][2] - m[1][2] * m[2][1]) -
               m[0][1] * (m[1][0] * m[2][2] - m[1][2] * m[2][0]) +
               m[0][2] * (m[1][0] * m[2][1] - m[1][1] * m[2][0]);
    }
};

// Unit quaternion w + xi + yj + zk, Hamilton convention; q.rotate(v) = q v q*.
struct Quat {
    double w = 1.0, x = 0.0, y = 0.0, z = 0.0;

    static Quat fromAxisAngle(const Vec3& axis, double angle_rad) {
        const Vec3 a = nvs::normalized(axis);
        const double s = std::sin(0.5 * angle_rad);
        return {std::cos(0.5 * angle_rad), a.x * s, a.y * s, a.z * s};
    }
    constexpr Quat operator*(const Quat& b) const {
        return {w * b.w - x * b.x - y * b.y - z * b.z, w * b.x + x * b.w + y * b.z - z * b.y,
                w * b.y - x * b.z + y * b.w + z * b.x, w * b.z + x * b.y - y * b.x + z * b.w};
    }
    constexpr Quat conjugate() const { return {w, -x, -y, -z}; }
    Quat normalized() const {
        const double n = std::sqrt(w * w + x * x + y * y + z * z);
        return {w / n, x / n, y / n, z / n};
    }
    Vec3 rotate(const Vec3& v) const {
        const Quat p{0.0, v.x, v.y, v.z};
        const Quat r = (*this) * p * conjugate();
        return {r.x, r.y, r.z};
    }
    Mat3 toMat3() const {
        Mat3 r;
        r.m[0][0] = 1 - 2 * (y * y + z * z), r.m[0][1] = 2 * (x * y - w * z),
        r.m[0][2] = 2 * (x * z + w * y);
        r.m[1][0] = 2 * (x * y + w * z), r.m[1][1] = 1 - 2 * (x * x + z * z),
        r.m[1][2] = 2 * (y * z - w * x);
        r.m[2][0] = 2 * (x * z - w * y), r.m[2][1] = 2 * (y * z + w * x),
        r.m[2][2] = 1 - 2 * (x * x + y * y);
        return r;
    }
};

// Rotation about one axis by angle (right-handed, active).
// The point where the line o + t·d meets the plane of triangle (a, b, c), as Embree reports a
// hit: t along d and the barycentric weights u of b and v of c (p = (1 − u − v) a + u b + v c).
// Möller & Trumbore, "Fast, minimum storage ray/triangle intersection", J. Graphics Tools 2(1),
// 1997. No inside test (the caller knows the triangle is hit); false only when d is parallel to
// the plane (or the triangle is degenerate).
inline bool rayPlaneOfTriangle(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b,
                               const Vec3& c, double* t, double* u, double* v) noexcept {
    const Vec3 e1 = b - a, e2 = c - a;
    const Vec3 p = cross(d, e2);
    const double det = dot(e1, p);
    if (det == 0.0) return false;
    const double inv = 1.0 / det;
    const Vec3 s = o - a;
    const Vec3 q = cross(s, e1);
    *u = dot(s, p) * inv;
    *v = dot(d, q) * inv;
    *t = dot(e2, q) * inv;
    return true;
}

Mat3 rotationX(double angle_rad);
Mat3 rotationY(double angle_rad);
Mat3 rotationZ(double angle_rad);

// Aerospace yaw-pitch-roll (Z-Y-X intrinsic): nedFromBody = Rz(yaw) · Ry(pitch) · Rx(roll).
// Yaw is the heading from north through east.
Mat3 nedFromBodyYpr(double yaw_rad, double pitch_rad, double roll_rad);
// Inverse of the above (pitch in [−π/2, π/2]).
void yprFromNedFromBody(const Mat3& nedFromBody, double* yaw_rad, double* pitch_rad,
                        double* roll_rad);

// ENU <-> NED (a reflection-free axis swap: x_e = y_n, y_e = x_n, z_e = −z_n).
constexpr Mat3 enuFromNed() {
    return Mat3::fromRows({0, 1, 0}, {1, 0, 0}, {0, 0, -1});
}

// Unit vector in ENU toward azimuth (from north through east) and altitude, and back.
Vec3 enuFromAzAlt(double az_rad, double alt_rad);
void azAltFromEnu(const Vec3& v_enu, double* az_rad, double* alt_rad);

// A site's local east-north-up frame on the WGS84 ellipsoid (NIMA TR8350.2, a = 6 378 137 m,
// e² = 6.69437999014e-3), through the radii of curvature at the site: east = Δλ·(N + h₀)·cos φ₀,
// north = Δφ·(M + h₀), up = h − h₀, with N = a/w and M = a(1 − e²)/w³, w = √(1 − e² sin² φ₀).
// Against the exact transformation (through Earth-centred coordinates, geometry_test.cpp) it
// leaves out the Earth's curvature (d²/2R: 0.08 m at 1 km) and the meridians' convergence
// (0.07 m north at 1 km east at 43°, 0.14 m at 60°): within 0.11 m (43°) and 0.16 m (60°) at
// 1 km along one axis, 0.24 m and 0.36 m at 1 km along both, heights ±100 m. No allocation, no
// throw.
class LocalTangentPlane {
  public:
    LocalTangentPlane() = default;
    LocalTangentPlane(double lat_deg, double lon_deg, double height_m) noexcept;
    // The ENU position [m] of a point given by geodetic latitude, longitude and height.
    Vec3 enuFrom(double lat_deg, double lon_deg, double height_m) const noexcept;

  private:
    double lat0_rad_ = 0.0, lon0_rad_ = 0.0, h0_m_ = 0.0;
    double meridianRadius_m_ = 0.0, primeVerticalRadius_m_ = 0.0;
};

}  // namespace nvs
