// The renderer as the runtime's render stage: same pixels as sim/render, independent of the
// thread count, pose from telemetry placed in the scene frame, lamps from the lamp mask.
#include "rt/render_stage/render_stage.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/core/error.h"
#include "sim/core/units.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::rt {
namespace {

std::filesystem::path rit(const char* name) {
    return std::filesystem::path(NVS_SOURCE_DIR) / "scenarios" / "rit" / name;
}

// The RIT scenario `name`, rendered with coarse tiles of `coarse` on `threads` threads.
Scenario ritScenario(const char* name, int coarse, int threads) {
    Scenario sc = loadScenario(rit(name), test::configDir());
    sc.renderCoarse = coarse;
    sc.renderThreads = threads;
    return sc;
}

TEST(SceneRenderStage, SamePixelsAsTheRendererWithOneAndTwoThreads) {
    auto one = SceneRenderStage::create(ritScenario("nolight.toml", 1, 1), test::dataDirs());
    auto two = SceneRenderStage::create(ritScenario("nolight.toml", 1, 2), test::dataDirs());
    ImageF a(768, 494), b(768, 494), direct(768, 494), band(768, 494), bandA(768, 494);
    FrameRequest req;
    req.t_sample_s = 0.0;
    req.platform.lampMask = one->initialLampMask();
    FrameMeta ma, mb;
    one->render(req, RadianceTarget{a.view(), bandA.view()}, ma);
    two->render(req, RadianceTarget{b.view(), {}}, mb);
    auto sr = ScenarioRenderer::create(rit("nolight.toml"), test::dataDirs(), 1);
    render::SerialExecutor exec;
    sr->renderer().render(sr->prepare(0.0), direct.view(), band.view(), exec);
    double sum = 0.0;
    for (int y = 0; y < 494; ++y) {
        for (int x = 0; x < 768; ++x) {
            ASSERT_EQ(a(x, y), b(x, y)) << x << "," << y;
            ASSERT_EQ(a(x, y), direct(x, y)) << x << "," << y;
            ASSERT_EQ(bandA(x, y), band(x, y)) << x << "," << y;  // into the loop's image
            sum += static_cast<double>(a(x, y));
        }
    }
    EXPECT_GT(sum, 0.0);
    EXPECT_EQ(ma.truthCount, mb.truthCount);
}

TEST(SceneRenderStage, TelemetryPoseIsPlacedInTheSceneFrame) {
    auto s = SceneRenderStage::create(ritScenario("nolight.toml", 4, 1), test::dataDirs());
    const auto& site = s->scenario().scenario().scene.site;
    PlatformState p;
    p.lat_deg = site.lat_deg;
    p.lon_deg = site.lon_deg;
    p.alt_m = site.height_m + 10.0;
    p.yaw_rad = kPi / 2;  // heading east
    scene::CameraPose pose = s->poseFor(p);
    EXPECT_NEAR(pose.position_m.x, 0.0, 1e-9);
    EXPECT_NEAR(pose.position_m.y, 0.0, 1e-9);
    EXPECT_NEAR(pose.position_m.z, 10.0, 1e-9);
    const Vec3 fwd = normalized(pose.target_m - pose.position_m);
    EXPECT_NEAR(fwd.x, 1.0, 1e-12);
    EXPECT_NEAR(pose.up.z, 1.0, 1e-12);
    // Pitch down 30°: the boresight points below the horizon.
    p.pitch_rad = -30.0 * kRadPerDeg;
    pose = s->poseFor(p);
    EXPECT_NEAR(normalized(pose.target_m - pose.position_m).z, -0.5, 1e-12);
    // 0.001° of latitude north is 111.1 m at 43° (WGS84 meridian radius of curvature).
    p.lat_deg = site.lat_deg + 0.001;
    p.pitch_rad = 0.0;
    pose = s->poseFor(p);
    EXPECT_NEAR(pose.position_m.y, 111.09, 0.05);
    // 0.001° of longitude east: (N + h) cos φ · 1.745e-5 rad ≈ 81.2 m.
    p.lat_deg = site.lat_deg;
    p.lon_deg = site.lon_deg + 0.001;
    pose = s->poseFor(p);
    EXPECT_NEAR(pose.position_m.x, 81.2, 0.2);
}

TEST(SceneRenderStage, LampMaskSwitchesLamps) {
    auto s = SceneRenderStage::create(ritScenario("stlamp.toml", 4, 1), test::dataDirs());
    ASSERT_NE(s->initialLampMask(), 0u);
    ImageF on(768, 494), off(768, 494);
    FrameRequest req;
    FrameMeta m;
    req.platform.lampMask = s->initialLampMask();
    s->render(req, RadianceTarget{on.view(), {}}, m);
    req.platform.lampMask = 0;
    s->render(req, RadianceTarget{off.view(), {}}, m);
    double sOn = 0.0, sOff = 0.0;
    for (int y = 0; y < 494; ++y) {
        for (int x = 0; x < 768; ++x) {
            sOn += static_cast<double>(on(x, y));
            sOff += static_cast<double>(off(x, y));
        }
    }
    EXPECT_GT(sOn, sOff * 1.01);
}

TEST(SceneRenderStage, AScenarioWithoutASceneIsASetupError) {
    Scenario sc = loadScenario(rit("nolight.toml"), test::configDir());
    sc.rendered = false;
    EXPECT_THROW(SceneRenderStage::create(sc, test::dataDirs()), SetupError);
}

}  // namespace
}  // namespace nvs::rt
