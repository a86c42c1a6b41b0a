// A camera rig's geometry (rt/compose/rig.h, docs/fusion.md) against what it must be:
//   - the ground-plane homography against the two cameras' own projection of plane points (the
//     pinhole model of msg::CameraGeometry, written out here), for random rigs;
//   - a mounting's lever arm and boresight angles against their definition (the aerospace
//     senses: yaw right, pitch up, roll clockwise as the image sees it);
//   - the published geometry of a rendered channel against the renderer's own hits: the scene
//     point a pixel sees projects back onto that pixel; with a misregistration it lands where
//     the misregistration puts it;
//   - the [[channel]] tables' errors.
#include "rt/compose/rig.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <random>
#include <vector>

#include "rt/compose/scenario.h"
#include "rt/render_stage/render_stage.h"
#include "sim/core/error.h"
#include "sim/core/units.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::rt {
namespace {

// A scene point's pixel in a camera (msg::CameraGeometry's definition).
bool project(const msg::CameraGeometry& g, const Vec3& X, double& u, double& v) {
    const Vec3 p{X.x, X.y, X.z};
    const double xc = g.R[0] * p.x + g.R[1] * p.y + g.R[2] * p.z + g.t_m[0];
    const double yc = g.R[3] * p.x + g.R[4] * p.y + g.R[5] * p.z + g.t_m[1];
    const double zc = g.R[6] * p.x + g.R[7] * p.y + g.R[8] * p.z + g.t_m[2];
    if (!(zc > 1e-6)) return false;
    u = g.fx_px * xc / zc + g.cx_px;
    v = g.fy_px * yc / zc + g.cy_px;
    return true;
}

render::PinholeCamera pinhole(int w, int h, double f_m, double px_m, double py_m) {
    render::PinholeCamera c;
    c.width = w;
    c.height = h;
    c.focalLength_m = f_m;
    c.pitchX_m = px_m;
    c.pitchY_m = py_m;
    return c;
}

TEST(RigGeometry, GroundHomographyMapsPlanePointsBetweenTheTwoCameras) {
    std::mt19937 rng(11);
    std::uniform_real_distribution<double> u01(0.0, 1.0);
    int checked = 0;
    for (int trial = 0; trial < 50; ++trial) {
        // A platform camera 5–300 m up looking down at 10–60° below the horizon, and a second
        // channel mounted up to 2 m away, turned up to 10°.
        scene::CameraPose base;
        base.position_m = {u01(rng) * 40 - 20, u01(rng) * 40 - 20, 5 + u01(rng) * 295};
        const double az = u01(rng) * 6.283, dep = (10 + u01(rng) * 50) * kRadPerDeg;
        base.target_m = base.position_m + Vec3{std::cos(dep) * std::sin(az),
                                               std::cos(dep) * std::cos(az), -std::sin(dep)};
        base.up = {0, 0, 1};
        Mount m;
        m.leverArm_m = {u01(rng) * 4 - 2, u01(rng) * 4 - 2, u01(rng) * 4 - 2};
        m.yaw_rad = (u01(rng) * 20 - 10) * kRadPerDeg;
        m.pitch_rad = (u01(rng) * 20 - 10) * kRadPerDeg;
        m.roll_rad = (u01(rng) * 20 - 10) * kRadPerDeg;
        const double z0 = u01(rng) * 4 - 2;
        const msg::CameraGeometry a = cameraGeometry(base, pinhole(768, 494, 0.036, 18e-6, 21e-6));
        const msg::CameraGeometry b =
            cameraGeometry(mountedPose(base, m), pinhole(640, 512, 0.018, 12e-6, 12e-6));
        double H[9];
        ASSERT_TRUE(groundHomography(a, b, z0, H));
        EXPECT_DOUBLE_EQ(H[8], 1.0);
        for (int i = 0; i < 40; ++i) {
            // A plane point seen by A: along A's ray through a random pixel.
            const Vec3 X{base.position_m.x + (u01(rng) - 0.5) * 200,
                         base.position_m.y + (u01(rng) - 0.5) * 200, z0};
            double ua, va, ub, vb;
            if (!project(a, X, ua, va) || !project(b, X, ub, vb)) continue;
            const double w = H[6] * ua + H[7] * va + H[8];
            const double uh = (H[0] * ua + H[1] * va + H[2]) / w;
            const double vh = (H[3] * ua + H[4] * va + H[5]) / w;
            EXPECT_NEAR(uh, ub, 1e-6 * (1 + std::fabs(ub)));
            EXPECT_NEAR(vh, vb, 1e-6 * (1 + std::fabs(vb)));
            ++checked;
        }
    }
    EXPECT_GT(checked, 500);
}

TEST(RigGeometry, ThePlaneSeenEdgeOnHasNoHomography) {
    scene::CameraPose base;
    base.position_m = {0, 0, 0};  // in the plane z = 0, looking along it
    base.target_m = {0, 1, 0};
    const msg::CameraGeometry a = cameraGeometry(base, pinhole(64, 64, 0.01, 1e-5, 1e-5));
    double H[9];
    EXPECT_FALSE(groundHomography(a, a, 0.0, H));
}

TEST(RigGeometry, AMountingMovesAndTurnsTheCameraAsItsAnglesSay) {
    scene::CameraPose base;
    base.position_m = {1, 2, 3};
    base.target_m = {1, 12, 3};  // looking north, level: right = east, down = −z
    base.up = {0, 0, 1};
    const auto axes = [](const scene::CameraPose& p, Vec3& f, Vec3& r, Vec3& d) {
        const msg::CameraGeometry g = cameraGeometry(p, pinhole(8, 8, 1, 1, 1));
        r = {g.R[0], g.R[1], g.R[2]};
        d = {g.R[3], g.R[4], g.R[5]};
        f = {g.R[6], g.R[7], g.R[8]};
    };
    Vec3 f, r, d;
    Mount arm;
    arm.leverArm_m = {0.5, 0.15, -0.2};  // forward, right, down (that is 0.2 m up)
    const scene::CameraPose moved = mountedPose(base, arm);
    EXPECT_NEAR(moved.position_m.x, 1.15, 1e-12);
    EXPECT_NEAR(moved.position_m.y, 2.5, 1e-12);
    EXPECT_NEAR(moved.position_m.z, 3.2, 1e-12);
    axes(moved, f, r, d);
    EXPECT_NEAR(f.y, 1.0, 1e-12);
    const double a = 7.0 * kRadPerDeg;
    Mount yaw;
    yaw.yaw_rad = a;  // turns right: toward east
    axes(mountedPose(base, yaw), f, r, d);
    EXPECT_NEAR(f.x, std::sin(a), 1e-12);
    EXPECT_NEAR(f.y, std::cos(a), 1e-12);
    Mount pitch;
    pitch.pitch_rad = a;  // up
    axes(mountedPose(base, pitch), f, r, d);
    EXPECT_NEAR(f.z, std::sin(a), 1e-12);
    Mount roll;
    roll.roll_rad = a;  // the right side goes down
    axes(mountedPose(base, roll), f, r, d);
    EXPECT_NEAR(r.z, -std::sin(a), 1e-12);
    EXPECT_NEAR(f.y, 1.0, 1e-12);
}

// The rit-fusion rig rendered: every pixel's hit point, projected with the published geometry,
// lands back on that pixel's centre; with a misregistration of the thermal channel it lands
// where the turn puts it (f·tan of the angle, to first order, across the image).
TEST(RigGeometry, PublishedGeometryIsTheRenderedOneAndAMisregistrationIsNot) {
    const std::filesystem::path file =
        test::sourceDir() / "scenarios" / "rit-fusion" / "scenario.toml";
    Scenario rig = loadScenario(file, test::configDir());
    ASSERT_EQ(rig.channels.size(), 2u);
    for (const double mis_deg : {0.0, 0.2}) {
        rig.channels[1].faults.misregistration_rad[0] = mis_deg * kRadPerDeg;
        for (std::size_t c = 0; c < 2; ++c) {
            const Scenario sc = channelScenario(rig, c);
            auto stage = SceneRenderStage::create(sc, test::dataDirs());
            const render::Renderer& r = stage->scenario().renderer();
            ImageF pe(sc.width, sc.height), band(sc.width, sc.height);
            FrameRequest req;
            req.platform = sc.platform;
            FrameMeta meta;
            stage->render(req, RadianceTarget{c == 1 ? ImageView<float>() : pe.view(), band.view()},
                          meta);
            ASSERT_TRUE(meta.camera.valid);
            ASSERT_EQ(meta.rig.channel, static_cast<int>(c));
            const bool turned = c == 1 && mis_deg != 0.0;
            double sumDu = 0.0, maxDv = 0.0;
            int n = 0;
            for (int y = 10; y < sc.height; y += 37) {
                for (int x = 10; x < sc.width; x += 41) {
                    Vec3 P;
                    int mat = -1, obj = -1;
                    if (!r.pixelHit(x, y, &P, &mat, &obj)) continue;
                    double u, v;
                    ASSERT_TRUE(project(meta.camera, P, u, v));
                    if (!turned) {
                        EXPECT_NEAR(u, x + 0.5, 0.02) << "channel " << c;
                        EXPECT_NEAR(v, y + 0.5, 0.02) << "channel " << c;
                    }
                    sumDu += u - (x + 0.5);
                    maxDv = std::max(maxDv, std::fabs(v - (y + 0.5)));
                    ++n;
                }
            }
            ASSERT_GT(n, 50);
            if (turned) {
                // Turned 0.2° right, the camera sees a point that far left of where the
                // published geometry puts it: the published pixel is f·tan(0.2°) to the right of
                // the true one (7.0 px at 1500 px of focal length; rows hardly move).
                const double expect = meta.camera.fx_px * std::tan(mis_deg * kRadPerDeg);
                EXPECT_NEAR(sumDu / n, expect, 0.05 * expect);
                EXPECT_LT(maxDv, 0.5);
            }
        }
    }
}

// The shared trigger counter against a brute-force merge: every frame started by three channels
// of unrelated rates (59.94, 30, 29.97 Hz) and phases, sorted by start time (ties: the channel
// listed first), is numbered 0, 1, 2, … in that order.
TEST(RigClock, CountsEveryChannelsFramesInOrderOfTime) {
    RigClock rc;
    rc.channels = 3;
    const double period_s[3] = {1001.0 / 60000.0, 1.0 / 30.0, 1001.0 / 30000.0};
    const double first_s[3] = {-0.5 / 59.94, 0.001 - 1.0 / 60.0, -1.5 * 1001.0 / 60000.0};
    for (int c = 0; c < 3; ++c) {
        rc.period_s[c] = period_s[c];
        rc.first_s[c] = first_s[c];
    }
    struct Start {
        double t_s;
        int c;
        std::int64_t k;
    };
    std::vector<Start> all;
    for (int c = 0; c < 3; ++c)
        for (std::int64_t k = 0; k < 3000; ++k)
            all.push_back({first_s[c] + static_cast<double>(k) * period_s[c], c, k});
    std::stable_sort(all.begin(), all.end(), [](const Start& a, const Start& b) {
        return a.t_s < b.t_s || (a.t_s == b.t_s && a.c < b.c);
    });
    // Only the starts before the earliest channel's last are complete in the list.
    double end_s = 1e300;
    for (int c = 0; c < 3; ++c)
        end_s = std::min(end_s, first_s[c] + 2999.0 * period_s[c]);
    std::int64_t n = 0;
    for (const Start& s : all) {
        if (s.t_s > end_s) break;
        EXPECT_EQ(rc.count(s.c, s.k), n) << "channel " << s.c << " frame " << s.k;
        ++n;
    }
    EXPECT_GT(n, 5900);
    // Two channels of one rate and phase: the first listed counts first.
    RigClock same;
    same.channels = 2;
    same.period_s[0] = same.period_s[1] = 0.1;
    EXPECT_EQ(same.count(0, 5), 10);
    EXPECT_EQ(same.count(1, 5), 11);
}

Scenario parse(const std::string& text) {
    // Relative paths resolve against the scenario's own folder: one inside scenarios/.
    return parseScenario(text, (test::sourceDir() / "scenarios" / "rit-fusion" / "x.toml").string(),
                         test::configDir());
}

const char* kHead = R"([scenario]
name = "rig"
duration_s = 0.1
[site]
lat_deg = 43.0
[scene]
file = "../rit/scene.toml"
)";

TEST(RigScenario, ChannelTablesAreCheckedWithTheirPlace) {
    const std::string two = R"(
[[channel]]
name = "a"
preset = "pulnix-ag5745ef3"
[[channel]]
name = "b"
preset = "pulnix-ag5745ef3"
lever_arm_m = [0.0, 0.2, 0.0]
boresight_deg = [1.0, 0.0, 0.0]
skew_s = 0.001
)";
    const Scenario ok = parse(std::string(kHead) + two);
    ASSERT_EQ(ok.channels.size(), 2u);
    EXPECT_EQ(ok.channels[1].name, "b");
    EXPECT_NEAR(ok.channels[1].mount.leverArm_m.y, 0.2, 1e-15);
    EXPECT_NEAR(ok.channels[1].mount.yaw_rad, kRadPerDeg, 1e-15);
    EXPECT_EQ(ok.channels[1].faults.skew_s, 0.001);
    EXPECT_EQ(channelScenario(ok, 1).channelIndex, 1);
    EXPECT_NE(ok.channels[0].format.camera.seed, ok.channels[1].format.camera.seed);
    const struct {
        std::string text, says;
    } bad[] = {
        {two + "[camera]\npreset = \"pulnix-ag5745ef3\"\n", "exclude each other"},
        {"[[channel]]\nname = \"a\"\npreset = \"pulnix-ag5745ef3\"\n", "2 to 4"},
        {R"(
[[channel]]
name = "a"
preset = "pulnix-ag5745ef3"
[[channel]]
name = "a"
preset = "pulnix-ag5745ef3"
)",
         "two channels are named"},
        {R"(
[[channel]]
name = "a b"
preset = "pulnix-ag5745ef3"
[[channel]]
name = "c"
preset = "pulnix-ag5745ef3"
)",
         "[A-Za-z0-9_-]"},
        {R"(
[[channel]]
name = "a"
preset = "pulnix-ag5745ef3"
lever_arm_m = [0.0, 0.2]
[[channel]]
name = "c"
preset = "pulnix-ag5745ef3"
)",
         "three numbers"},
        {R"(
[[channel]]
name = "a"
preset = "pulnix-ag5745ef3"
misregistration_deg = [11.0, 0.0, 0.0]
[[channel]]
name = "c"
preset = "pulnix-ag5745ef3"
)",
         "within"},
        {R"(
[[channel]]
name = "a"
preset = "pulnix-ag5745ef3"
[[channel]]
name = "c"
preset = "boson-640"
)",
         "[thermal]"},
    };
    for (const auto& b : bad) {
        try {
            (void)parse(std::string(kHead) + b.text);
            ADD_FAILURE() << "accepted:\n" << b.text;
        } catch (const SetupError& e) {
            EXPECT_NE(std::string(e.what()).find(b.says), std::string::npos) << e.what();
            EXPECT_NE(std::string(e.what()).find("x.toml:"), std::string::npos) << e.what();
        }
    }
    try {
        (void)parse(R"([scenario]
name = "rig"
frame_rate_hz = 30.0
[site]
lat_deg = 43.0
[scene]
file = "../rit/scene.toml"
)" + two);
        ADD_FAILURE() << "frame_rate_hz in [scenario] of a rig accepted";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("in each channel"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace nvs::rt
