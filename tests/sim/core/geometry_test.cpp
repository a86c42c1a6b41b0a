#include "sim/core/geometry.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "sim/core/units.h"

namespace nvs {
namespace {

void expectNear(const Vec3& a, const Vec3& b, double tol = 1e-12) {
    EXPECT_NEAR(a.x, b.x, tol);
    EXPECT_NEAR(a.y, b.y, tol);
    EXPECT_NEAR(a.z, b.z, tol);
}

TEST(Geometry, VectorAlgebra) {
    const Vec3 x{1, 0, 0}, y{0, 1, 0}, z{0, 0, 1};
    EXPECT_EQ(cross(x, y), z);
    EXPECT_EQ(cross(y, z), x);
    EXPECT_EQ(dot(x + y, y - z), 1.0);
    EXPECT_DOUBLE_EQ(norm(Vec3{3, 4, 12}), 13.0);
    expectNear(normalized(Vec3{0, 0, 5}), z);
}

TEST(Geometry, YawPitchRollIsAerospaceConvention) {
    // Yaw 90°: the body's forward axis points east, i.e. NED (0, 1, 0).
    expectNear(nedFromBodyYpr(kPi / 2, 0, 0) * Vec3{1, 0, 0}, {0, 1, 0});
    // Pitch up 30°: forward tilts up, i.e. negative NED down component.
    expectNear(nedFromBodyYpr(0, kPi / 6, 0) * Vec3{1, 0, 0}, {std::cos(kPi / 6), 0, -0.5});
    // Roll right 90°: the right wing points down.
    expectNear(nedFromBodyYpr(0, 0, kPi / 2) * Vec3{0, 1, 0}, {0, 0, 1});
}

TEST(Geometry, RotationsAreOrthonormalAndRoundTrip) {
    const Mat3 r = nedFromBodyYpr(0.3, -0.4, 1.1);
    const Mat3 i = r * r.transposed();
    for (int a = 0; a < 3; ++a) {
        for (int b = 0; b < 3; ++b)
            EXPECT_NEAR(i.m[a][b], a == b ? 1.0 : 0.0, 1e-12);
    }
    EXPECT_NEAR(r.det(), 1.0, 1e-12);
    double yaw = 0, pitch = 0, roll = 0;
    yprFromNedFromBody(r, &yaw, &pitch, &roll);
    EXPECT_NEAR(yaw, 0.3, 1e-12);
    EXPECT_NEAR(pitch, -0.4, 1e-12);
    EXPECT_NEAR(roll, 1.1, 1e-12);
}

TEST(Geometry, QuaternionAgreesWithMatrix) {
    const Vec3 axis{1, 2, -0.5};
    const double angle = 0.77;
    const Quat q = Quat::fromAxisAngle(axis, angle);
    const Vec3 v{0.2, -1.0, 3.0};
    expectNear(q.rotate(v), q.toMat3() * v);
    // Rodrigues' formula as the independent reference.
    const Vec3 k = normalized(axis);
    const Vec3 rod = v * std::cos(angle) + cross(k, v) * std::sin(angle) +
                     k * (dot(k, v) * (1 - std::cos(angle)));
    expectNear(q.rotate(v), rod);
    // Composition: (q2 q1) rotates by q1 then q2.
    const Quat q2 = Quat::fromAxisAngle({0, 0, 1}, -1.2);
    expectNear((q2 * q).rotate(v), q2.rotate(q.rotate(v)));
    expectNear((q2 * q).toMat3() * v, q2.toMat3() * (q.toMat3() * v));
}

TEST(Geometry, AzimuthAltitudeEnuRoundTrip) {
    expectNear(enuFromAzAlt(0, 0), {0, 1, 0});          // north
    expectNear(enuFromAzAlt(kPi / 2, 0), {1, 0, 0});    // east
    expectNear(enuFromAzAlt(1.0, kPi / 2), {0, 0, 1});  // zenith
    for (double az : {0.1, 2.0, 4.0, 6.2}) {
        for (double alt : {-1.2, 0.0, 0.7}) {
            double a = 0, h = 0;
            azAltFromEnu(enuFromAzAlt(az, alt) * 3.0, &a, &h);
            EXPECT_NEAR(a, az, 1e-12);
            EXPECT_NEAR(h, alt, 1e-12);
        }
    }
    // ENU <-> NED swap: north is y in ENU and x in NED.
    expectNear(enuFromNed() * Vec3{1, 0, 0}, {0, 1, 0});
    expectNear(enuFromNed() * Vec3{0, 0, 1}, {0, 0, -1});
}

// The exact transformation, independent of the code under test: geodetic → Earth-centred
// (X = (N + h) cos φ cos λ, Y = (N + h) cos φ sin λ, Z = (N(1 − e²) + h) sin φ, WGS84) and the
// difference rotated into the site's east-north-up axes.
Vec3 exactEnu(double lat0_deg, double lon0_deg, double h0_m, double lat_deg, double lon_deg,
              double h_m) {
    constexpr double a = 6378137.0, e2 = 6.69437999014e-3;
    const auto ecef = [&](double lat, double lon, double h) {
        const double p = lat * kRadPerDeg, l = lon * kRadPerDeg;
        const double n = a / std::sqrt(1.0 - e2 * std::sin(p) * std::sin(p));
        return Vec3{(n + h) * std::cos(p) * std::cos(l), (n + h) * std::cos(p) * std::sin(l),
                    (n * (1.0 - e2) + h) * std::sin(p)};
    };
    const Vec3 d = ecef(lat_deg, lon_deg, h_m) - ecef(lat0_deg, lon0_deg, h0_m);
    const double p = lat0_deg * kRadPerDeg, l = lon0_deg * kRadPerDeg;
    return {-std::sin(l) * d.x + std::cos(l) * d.y,
            -std::sin(p) * std::cos(l) * d.x - std::sin(p) * std::sin(l) * d.y + std::cos(p) * d.z,
            std::cos(p) * std::cos(l) * d.x + std::cos(p) * std::sin(l) * d.y + std::sin(p) * d.z};
}

TEST(LocalTangentPlane, WithinItsStatedErrorOfTheExactTransformation) {
    // The RIT lot, the equator, 60° N; points out to 1 km along each axis and ±100 m in height.
    for (const Vec3& site :
         {Vec3{43.0857, -77.6745, 160.0}, Vec3{0.0, 10.0, 0.0}, Vec3{60.0, 25.0, 50.0}}) {
        const LocalTangentPlane ltp(site.x, site.y, site.z);
        const Vec3 at = ltp.enuFrom(site.x, site.y, site.z);
        EXPECT_EQ(at.x, 0.0);
        EXPECT_EQ(at.y, 0.0);
        EXPECT_EQ(at.z, 0.0);
        double worstAxis = 0.0, worst = 0.0;
        // About ±1 km north and east (111 km a degree of latitude).
        const double kmLat_deg = 1.0 / 111.0, kmLon_deg = kmLat_deg / std::cos(site.x * kRadPerDeg);
        for (double dn : {-1.0, 0.0, 1.0}) {
            for (double de : {-1.0, 0.0, 1.0}) {
                for (double dh : {-100.0, 0.0, 100.0}) {
                    const double lat = site.x + dn * kmLat_deg, lon = site.y + de * kmLon_deg;
                    const Vec3 e = exactEnu(site.x, site.y, site.z, lat, lon, site.z + dh);
                    const double err = norm(ltp.enuFrom(lat, lon, site.z + dh) - e);
                    worst = std::max(worst, err);
                    if (dn == 0.0 || de == 0.0) worstAxis = std::max(worstAxis, err);
                }
            }
        }
        std::printf("site %.2f°: worst %.3f m (one axis %.3f m)\n", site.x, worst, worstAxis);
        EXPECT_LT(worst, 0.36);
        EXPECT_LT(worstAxis, 0.16);
        if (site.x < 45.0) {
            EXPECT_LT(worstAxis, 0.11);
            EXPECT_LT(worst, 0.24);
        }
    }
}

}  // namespace
}  // namespace nvs
