// The sky seen directly: every pixel whose ray leaves the scene shows the atmosphere table's sky
// radiance for its direction (night sky + E_toa × lunar sky radiance at the Moon's zenith and
// the azimuth from the Moon), looked up here independently of the renderer through the table's
// own trilinear interpolation, and the Moon's disk shows E☾/Ω☾.

#include <gtest/gtest.h>

#include <cmath>

#include "rt/compose/scene_setup.h"
#include "sim/render/renderer.h"
#include "sim/sky/sky_model.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::render {
using rt::renderConfigFor;
using rt::ScenarioRenderer;
namespace {

constexpr double kPi = 3.14159265358979323846;

// Unit direction of pixel centre (px, py) for a camera at pose p (pinhole; image x along the
// camera's right, y down).
Vec3 pixelDirection(const scene::CameraPose& p, const PinholeCamera& c, double px, double py) {
    const Vec3 fwd = normalized(p.target_m - p.position_m);
    const Vec3 right = normalized(cross(fwd, p.up));
    const Vec3 up = cross(right, fwd);
    const double u = (px - 0.5 * c.width) * c.pitchX_m;
    const double v = (py - 0.5 * c.height) * c.pitchY_m;
    return normalized(fwd * c.focalLength_m + right * u - up * v);
}

TEST(SkyInView, MatchesTheAtmosphereTableAndTheMoonDisk) {
    auto sr = ScenarioRenderer::create(test::sourceDir() / "scenarios/rit/nolight.toml",
                                       test::dataDirs());
    Renderer& r = sr->renderer();
    FrameSky sky = sr->prepare(0.0);
    sky.starCount = 0;  // stars in view: star_test.cpp
    ASSERT_TRUE(sky.moonUp);
    // Camera on the roof looking at the Moon.
    scene::CameraPose pose = sr->scene().camera;
    pose.target_m = pose.position_m + sky.moonDir_enu * 10.0;
    pose.up = {0.0, 0.0, 1.0};
    pose.twist_rad = 0.0;
    r.setCamera(pose);
    r.setTerms(kTermInView);
    const PinholeCamera& cam = r.camera();
    ImageF pe(cam.width, cam.height), w(cam.width, cam.height);
    SerialExecutor ex;
    r.render(sky, pe.view(), w.view(), ex);

    const auto& t = sr->sky().table();
    const double omega = kPi * sky.moonAngularRadius_rad * sky.moonAngularRadius_rad;
    int sky_px = 0, disk_px = 0;
    double worst = 0.0;
    for (int y = 0; y < cam.height; y += 7) {
        for (int x = 0; x < cam.width; x += 5) {
            Vec3 p;
            int m, o;
            if (r.pixelHit(x, y, &p, &m, &o)) continue;
            const Vec3 d = pixelDirection(pose, cam, x + 0.5, y + 0.5);
            const double vz = std::acos(d.z);
            const double rel = std::atan2(d.x, d.y) - sky.moonAz_rad;
            const bool disk = dot(d, sky.moonDir_enu) > std::cos(sky.moonAngularRadius_rad);
            for (int b = 0; b < kBands; ++b) {
                const int tb = sr->tableBands()[static_cast<std::size_t>(b)];
                double want = t.nightSkyRadiance(tb, vz) +
                              sky.moonToa[b] * t.skyRadiance(tb, vz, rel, sky.moonZenith_rad);
                if (disk) want += sky.moonNormal[b] / omega;
                const double got = static_cast<double>(b == kBandPe ? pe(x, y) : w(x, y));
                worst = std::max(worst, std::abs(got / want - 1.0));
                EXPECT_NEAR(got / want, 1.0, 2e-4) << x << "," << y << " band " << b;
            }
            ++sky_px;
            disk_px += dot(d, sky.moonDir_enu) > std::cos(sky.moonAngularRadius_rad) ? 1 : 0;
        }
    }
    // The Moon's disk (0.5° wide) at the image centre.
    const int cx = cam.width / 2, cy = cam.height / 2;
    const Vec3 dc = pixelDirection(pose, cam, cx + 0.5, cy + 0.5);
    ASSERT_GT(dot(dc, sky.moonDir_enu), std::cos(sky.moonAngularRadius_rad));
    const double disk = sky.moonNormal[kBandPe] / omega;
    EXPECT_GT(static_cast<double>(pe(cx, cy)), disk);
    EXPECT_LT(static_cast<double>(pe(cx, cy)), disk * 1.01);
    std::printf("sky in view: %d sampled sky pixels (%d on the Moon's disk), worst %.2e\n", sky_px,
                disk_px, worst);
    EXPECT_GT(sky_px, 2000);
}

}  // namespace
}  // namespace nvs::render
