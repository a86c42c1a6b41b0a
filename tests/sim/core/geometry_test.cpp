#include "sim/core/geometry.h"

#include <gtest/gtest.h>

#include <cmath>

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

}  // namespace
}  // namespace nvs
