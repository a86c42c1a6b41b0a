#include "rt/compose/rig.h"

#include <cmath>

namespace nvs::rt {

namespace {

// 3×3 inverse by the adjugate; false when singular.
bool invert3(const double a[9], double out[9]) noexcept {
    const double c0 = a[4] * a[8] - a[5] * a[7];
    const double c1 = a[5] * a[6] - a[3] * a[8];
    const double c2 = a[3] * a[7] - a[4] * a[6];
    const double det = a[0] * c0 + a[1] * c1 + a[2] * c2;
    if (!(std::fabs(det) > 1e-300) || !std::isfinite(det)) return false;
    const double k = 1.0 / det;
    out[0] = c0 * k;
    out[1] = (a[2] * a[7] - a[1] * a[8]) * k;
    out[2] = (a[1] * a[5] - a[2] * a[4]) * k;
    out[3] = c1 * k;
    out[4] = (a[0] * a[8] - a[2] * a[6]) * k;
    out[5] = (a[2] * a[3] - a[0] * a[5]) * k;
    out[6] = c2 * k;
    out[7] = (a[1] * a[6] - a[0] * a[7]) * k;
    out[8] = (a[0] * a[4] - a[1] * a[3]) * k;
    return true;
}

// G = K [r1 r2 r3·z0 + t] of a camera (see rig.h).
void planeMap(const msg::CameraGeometry& g, double z0_m, double G[9]) noexcept {
    const double K[9] = {g.fx_px, 0.0, g.cx_px, 0.0, g.fy_px, g.cy_px, 0.0, 0.0, 1.0};
    double M[9];
    for (int i = 0; i < 3; ++i) {
        M[3 * i] = g.R[3 * i];
        M[3 * i + 1] = g.R[3 * i + 1];
        M[3 * i + 2] = g.R[3 * i + 2] * z0_m + g.t_m[i];
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
            G[3 * i + j] = K[3 * i] * M[j] + K[3 * i + 1] * M[3 + j] + K[3 * i + 2] * M[6 + j];
    }
}

}  // namespace

std::int64_t RigClock::count(int c, std::int64_t k) const noexcept {
    const double start_s = first_s[c] + static_cast<double>(k) * period_s[c];
    std::int64_t n = k;  // its own channel's earlier frames
    for (int j = 0; j < channels; ++j) {
        if (j == c) continue;
        // Frames m ≥ 0 of channel j with first_j + m·P_j < start (or equal, j listed first).
        const double m = (start_s - first_s[j]) / period_s[j];
        if (!(m > -1e-9)) continue;
        const double whole = std::round(m);
        const bool tie = std::fabs(m - whole) < 1e-9;
        n += tie ? static_cast<std::int64_t>(whole) + (j < c ? 1 : 0)
                 : static_cast<std::int64_t>(std::ceil(m));
    }
    return n;
}

scene::CameraPose mountedPose(const scene::CameraPose& base, const Mount& m) noexcept {
    Vec3 fwd, right, up;
    scene::cameraAxes(base, &fwd, &right, &up);
    const Vec3 down = -up;
    // The mounted camera's axes in the platform camera's body frame, then in the scene's.
    const Mat3 bodyFromMount = nedFromBodyYpr(m.yaw_rad, m.pitch_rad, m.roll_rad);
    const auto toScene = [&](const Vec3& v) { return fwd * v.x + right * v.y + down * v.z; };
    scene::CameraPose p;
    p.position_m = base.position_m + toScene(m.leverArm_m);
    const Vec3 f = toScene(bodyFromMount * Vec3{1.0, 0.0, 0.0});
    p.target_m = p.position_m + f;
    p.up = -toScene(bodyFromMount * Vec3{0.0, 0.0, 1.0});
    p.twist_rad = 0.0;
    return p;
}

msg::CameraGeometry cameraGeometry(const scene::CameraPose& pose,
                                   const render::PinholeCamera& pin) noexcept {
    Vec3 fwd, right, up;
    scene::cameraAxes(pose, &fwd, &right, &up);
    return cameraGeometry(pose.position_m, right, up, fwd, pin);
}

msg::CameraGeometry cameraGeometry(const Vec3& position_m, const Vec3& right, const Vec3& up,
                                   const Vec3& forward, const render::PinholeCamera& pin) noexcept {
    msg::CameraGeometry g;
    g.valid = true;
    g.width = pin.width;
    g.height = pin.height;
    g.fx_px = pin.focalLength_m / pin.pitchX_m;
    g.fy_px = pin.focalLength_m / pin.pitchY_m;
    g.cx_px = 0.5 * pin.width;
    g.cy_px = 0.5 * pin.height;
    const Vec3 rows[3] = {right, up * -1.0, forward};
    for (int i = 0; i < 3; ++i) {
        g.R[3 * i] = rows[i].x;
        g.R[3 * i + 1] = rows[i].y;
        g.R[3 * i + 2] = rows[i].z;
        g.t_m[i] = -dot(rows[i], position_m);
    }
    return g;
}

bool groundHomography(const msg::CameraGeometry& a, const msg::CameraGeometry& b, double z0_m,
                      double H[9]) noexcept {
    if (!a.valid || !b.valid) return false;
    double Ga[9], Gb[9], Gai[9];
    planeMap(a, z0_m, Ga);
    planeMap(b, z0_m, Gb);
    if (!invert3(Ga, Gai)) return false;
    double h[9];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j)
            h[3 * i + j] =
                Gb[3 * i] * Gai[j] + Gb[3 * i + 1] * Gai[3 + j] + Gb[3 * i + 2] * Gai[6 + j];
    }
    if (!(std::fabs(h[8]) > 1e-12) || !std::isfinite(h[8])) return false;
    for (int i = 0; i < 9; ++i)
        H[i] = h[i] / h[8];
    // Edge-on: the plane's image in B collapses (G_B singular).
    double Gbi[9];
    return invert3(Gb, Gbi);
}

}  // namespace nvs::rt
