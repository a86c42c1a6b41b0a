// The last line of defence before Embree (rt/render_stage): a platform state that is not
// finite — telemetry is checked where it enters, so this is never expected — renders with the
// last good camera and time instead of reaching rtcIntersect16, which asserts on NaN rays.
#include <gtest/gtest.h>

#include <cmath>
#include <limits>

#include "rt/render_stage/render_stage.h"
#include "sim/core/units.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::rt {
namespace {

TEST(RenderGuard, NonFinitePoseRendersWithTheLastGoodCamera) {
    Scenario sc =
        loadScenario(std::filesystem::path(NVS_SOURCE_DIR) / "scenarios" / "rit" / "nolight.toml",
                     test::configDir());
    sc.renderCoarse = 8;
    sc.renderThreads = 1;
    auto stage = SceneRenderStage::create(sc, test::dataDirs());
    const auto& site = stage->scenario().scenario().scene.site;
    FrameRequest req;
    req.t_sample_s = 0.0;
    req.platform.lampMask = stage->initialLampMask();
    req.platform.poseFromTelemetry = true;
    req.platform.lat_deg = site.lat_deg;
    req.platform.lon_deg = site.lon_deg;
    req.platform.alt_m = site.height_m + 2.0;
    req.platform.yaw_rad = 0.5;
    req.platform.pitch_rad = -10.0 * kRadPerDeg;
    ImageF good(sc.width, sc.height), held(sc.width, sc.height), band(sc.width, sc.height);
    FrameMeta meta;
    stage->render(req, RadianceTarget{good.view(), band.view()}, meta);
    EXPECT_EQ(stage->heldFrames(), 0);
    const double nan = std::numeric_limits<double>::quiet_NaN();
    for (double* field : {&req.platform.roll_rad, &req.platform.lat_deg, &req.platform.alt_m}) {
        const double keep = *field;
        *field = nan;
        stage->render(req, RadianceTarget{held.view(), band.view()}, meta);
        *field = keep;
        for (int y = 0; y < sc.height; ++y)
            for (int x = 0; x < sc.width; ++x)
                ASSERT_EQ(held(x, y), good(x, y)) << x << "," << y;
    }
    EXPECT_EQ(stage->heldFrames(), 3);
    req.platform.utc_unix_s = std::numeric_limits<double>::infinity();
    stage->render(req, RadianceTarget{held.view(), band.view()}, meta);
    EXPECT_EQ(stage->heldFrames(), 4);
    EXPECT_FALSE(
        SceneRenderStage::poseUsable(scene::CameraPose{{1e9, 0, 0}, {0, 1, 0}, {0, 0, 1}, 0}));
}

}  // namespace
}  // namespace nvs::rt
