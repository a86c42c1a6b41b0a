// The OpenGL primary visibility (RenderConfig::primaryVisibility = kGl) against Embree's on the
// shipped scenes: the RIT scenario's fixed camera, the airborne pass's first pose over the
// airborne RIT scene, and the vehicle-drive truck moved under the fixed camera (GL vertex
// upload and the partial rectangle). Per pixel of the two geometry buffers:
//   - hit or miss, object and material agree except along sub-pixel edges: at most 0.5 % of the
//     pixels differ, and each differing pixel has, within one pixel, a neighbour whose Embree
//     (hit, object, material) differs from its own (an object or material edge), or both paths
//     hit the same point (within 10⁻⁴ of the range) on coplanar overlapping faces, a tie;
//   - where both hit the same object: position within 10⁻⁴ of the range, normal within 0.1°,
//     sky-view factor within 10⁻³, or (across a triangle edge: the sky-view factor is per
//     triangle) the normal and sky-view factor of the Embree pixels on the object within two
//     pixels, and the position within 10⁻³ of the range.
// The tests skip (GTEST_SKIP, printing why) only when no OpenGL backend can be created.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include "rt/compose/scene_setup.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::render {
namespace {

struct GBuffer {
    int w = 0, h = 0;
    std::vector<int> obj, mat;  // -1 on a miss
    std::vector<Vec3> p, n;
    std::vector<double> svf;
    int at(int x, int y) const { return y * w + x; }
};

GBuffer grab(const Renderer& r) {
    GBuffer g;
    g.w = r.camera().width;
    g.h = r.camera().height;
    const std::size_t np = static_cast<std::size_t>(g.w) * g.h;
    g.obj.assign(np, -1);
    g.mat.assign(np, -1);
    g.p.assign(np, {});
    g.n.assign(np, {});
    g.svf.assign(np, 0.0);
    for (int y = 0; y < g.h; ++y) {
        for (int x = 0; x < g.w; ++x) {
            const auto i = static_cast<std::size_t>(g.at(x, y));
            int m = -1, o = -1;
            if (!r.pixelHit(x, y, &g.p[i], &m, &o)) continue;
            g.obj[i] = o;
            g.mat[i] = m;
            r.pixelSurface(x, y, &g.n[i], &g.svf[i]);
        }
    }
    return g;
}

struct Agreement {
    int pixels = 0, hits = 0, labelDiffer = 0, labelDifferOffEdge = 0, coplanarTies = 0;
    int surfaceChecked = 0, surfaceOff = 0, surfaceOffNoNeighbour = 0;
    double worstRel = 0.0, worstAngle_deg = 0.0, worstSvf = 0.0;  // same-pixel, non-edge
};

bool surfaceAgrees(const GBuffer& e, std::size_t j, const GBuffer& g, std::size_t i,
                   const Vec3& cam, double* rel, double* ang_deg, double* dsvf) {
    const double range = norm(e.p[j] - cam);
    *rel = norm(g.p[i] - e.p[j]) / range;
    *ang_deg = std::acos(std::clamp(dot(g.n[i], e.n[j]), -1.0, 1.0)) * 180.0 / M_PI;
    *dsvf = std::abs(g.svf[i] - e.svf[j]);
    return *rel <= 1e-4 && *ang_deg <= 0.1 && *dsvf <= 1e-3;
}

Agreement compare(const GBuffer& e, const GBuffer& g, const Vec3& cam) {
    Agreement a;
    const auto label = [](const GBuffer& b, int i) { return b.obj[i] * 65536 + b.mat[i]; };
    for (int y = 0; y < e.h; ++y) {
        for (int x = 0; x < e.w; ++x) {
            const int i = e.at(x, y);
            ++a.pixels;
            const auto ui = static_cast<std::size_t>(i);
            if (label(e, i) != label(g, i)) {
                ++a.labelDiffer;
                bool edge = false;
                for (int dy = -1; dy <= 1; ++dy)
                    for (int dx = -1; dx <= 1; ++dx) {
                        const int xx = x + dx, yy = y + dy;
                        if (xx < 0 || yy < 0 || xx >= e.w || yy >= e.h) continue;
                        edge = edge || label(e, e.at(xx, yy)) != label(e, i);
                    }
                // Coplanar overlapping faces (the RIT building has some, with two materials):
                // both hit the same point, and which face wins is a tie.
                const bool tie = e.obj[ui] >= 0 && g.obj[ui] >= 0 &&
                                 norm(g.p[ui] - e.p[ui]) <= 1e-4 * norm(e.p[ui] - cam);
                if (!edge && tie) ++a.coplanarTies;
                if (!edge && !tie) ++a.labelDifferOffEdge;
                continue;
            }
            if (e.obj[ui] < 0) continue;
            ++a.hits;
            ++a.surfaceChecked;
            double rel, ang, ds;
            if (surfaceAgrees(e, ui, g, ui, cam, &rel, &ang, &ds)) {
                a.worstRel = std::max(a.worstRel, rel);
                a.worstAngle_deg = std::max(a.worstAngle_deg, ang);
                a.worstSvf = std::max(a.worstSvf, ds);
                continue;
            }
            ++a.surfaceOff;
            // A triangle edge: the GL hit is on a neighbouring triangle of the object (the
            // sky-view factor is interpolated per triangle, so it steps there). Its normal is
            // that of one of the Embree pixels on the object within two pixels (a sliver
            // triangle or the image border can leave the nearest 8 without the other triangle),
            // its sky-view factor within their range, its position within 10⁻³ of the range.
            double fLo = e.svf[ui], fHi = e.svf[ui];
            bool normalSeen = false;
            for (int dy = -2; dy <= 2; ++dy)
                for (int dx = -2; dx <= 2; ++dx) {
                    const int xx = x + dx, yy = y + dy;
                    if (xx < 0 || yy < 0 || xx >= e.w || yy >= e.h) continue;
                    const auto j = static_cast<std::size_t>(e.at(xx, yy));
                    if (e.obj[j] != e.obj[ui]) continue;
                    fLo = std::min(fLo, e.svf[j]);
                    fHi = std::max(fHi, e.svf[j]);
                    normalSeen =
                        normalSeen ||
                        std::acos(std::clamp(dot(g.n[ui], e.n[j]), -1.0, 1.0)) * 180.0 / M_PI <=
                            0.1;
                }
            const bool neighbour =
                normalSeen && rel <= 1e-3 && g.svf[ui] >= fLo - 1e-3 && g.svf[ui] <= fHi + 1e-3;
            if (!neighbour) ++a.surfaceOffNoNeighbour;
        }
    }
    return a;
}

void expectAgreement(const char* what, const Agreement& a) {
    std::printf(
        "%s: %d pixels, %d hits; object/material differ %d (%.3f %%; %d coplanar ties, "
        "%d neither tie nor by an edge); "
        "surface off at %d (%.3f %%, %d with no neighbour); worst elsewhere: "
        "|Δp|/range %.2g, normal %.3g°, ΔF %.2g\n",
        what, a.pixels, a.hits, a.labelDiffer, 100.0 * a.labelDiffer / a.pixels, a.coplanarTies,
        a.labelDifferOffEdge, a.surfaceOff, 100.0 * a.surfaceOff / a.pixels,
        a.surfaceOffNoNeighbour, a.worstRel, a.worstAngle_deg, a.worstSvf);
    EXPECT_GT(a.hits, a.pixels / 4) << what;
    EXPECT_LE(a.labelDiffer, a.pixels / 200) << what;  // ≤ 0.5 %
    EXPECT_EQ(a.labelDifferOffEdge, 0) << what;
    EXPECT_LE(a.surfaceOff, a.pixels / 200) << what;
    EXPECT_EQ(a.surfaceOffNoNeighbour, 0) << what;
}

// Two renderers of one scenario, Embree's and OpenGL's primary visibility; nullptr for the GL
// one (and the reason) when no backend can be created.
struct Pair {
    std::unique_ptr<rt::ScenarioRenderer> embree, gl;
    std::string why;
};

Pair openPair(const std::filesystem::path& scenario) {
    Pair p;
    rt::Scenario sc = rt::loadScenario(scenario, test::configDir());
    p.embree = rt::ScenarioRenderer::create(sc, test::dataDirs());
    sc.primaryVisibility = PrimaryVisibility::kGl;
    try {
        p.gl = rt::ScenarioRenderer::create(sc, test::dataDirs());
    } catch (const SetupError& e) {
        p.why = e.what();
    }
    return p;
}

void renderBoth(Pair& p, double t_s) {
    for (auto* sr : {p.embree.get(), p.gl.get()}) {
        const FrameSky sky = sr->prepare(t_s);
        const PinholeCamera& c = sr->renderer().camera();
        ImageF pe(c.width, c.height), bw(c.width, c.height);
        SerialExecutor ex;
        sr->renderer().render(sky, pe.view(), bw.view(), ex);
    }
}

TEST(GlPrimary, RitFixedCameraAgreesWithEmbree) {
    Pair p = openPair(test::sourceDir() / "scenarios/rit/stlamp.toml");
    if (!p.gl) GTEST_SKIP() << p.why;
    ASSERT_TRUE(p.gl->renderer().primaryByGl());
    std::printf("%s\n", p.gl->renderer().primaryVisibilityNote().c_str());
    renderBoth(p, 0.0);
    const Vec3 cam = p.embree->scene().camera.position_m;
    expectAgreement("RIT stlamp", compare(grab(p.embree->renderer()), grab(p.gl->renderer()), cam));
}

// The airborne pass's first pose (scenarios/airborne-pass/make_flight.py at t = 0: 300 m up,
// 360 m before the site along heading 10°, pitched 45° down, no roll) over its scene.
TEST(GlPrimary, AirbornePassFirstPoseAgreesWithEmbree) {
    Pair p = openPair(test::sourceDir() / "scenarios/airborne-pass/scenario.toml");
    if (!p.gl) GTEST_SKIP() << p.why;
    const double hd = 10.0 * M_PI / 180.0, pitch = -45.0 * M_PI / 180.0, s = -360.0;
    scene::CameraPose pose;
    pose.position_m = {s * std::sin(hd), s * std::cos(hd), 300.0};
    const Vec3 fwd{std::sin(hd) * std::cos(pitch), std::cos(hd) * std::cos(pitch), std::sin(pitch)};
    pose.target_m = pose.position_m + fwd;
    pose.up = {0.0, 0.0, 1.0};
    p.embree->renderer().setCamera(pose);
    p.gl->renderer().setCamera(pose);
    renderBoth(p, 0.0);
    expectAgreement("airborne pass, first pose",
                    compare(grab(p.embree->renderer()), grab(p.gl->renderer()), pose.position_m));
}

// The truck of vehicle-drive moves under the fixed camera: the GL pass uploads its vertices and
// redoes the rectangle its boxes cover; the result still agrees with Embree's at each time.
TEST(GlPrimary, MovingTruckAgreesWithEmbree) {
    Pair p = openPair(test::sourceDir() / "scenarios/vehicle-drive/scenario.toml");
    if (!p.gl) GTEST_SKIP() << p.why;
    const Vec3 cam = p.embree->scene().camera.position_m;
    for (double t_s : {0.0, 1.5, 3.0}) {
        renderBoth(p, t_s);
        const std::string what = "vehicle-drive t = " + std::to_string(t_s) + " s";
        expectAgreement(what.c_str(),
                        compare(grab(p.embree->renderer()), grab(p.gl->renderer()), cam));
    }
}

TEST(GlPrimary, AutoPicksAPathAndSaysWhich) {
    rt::Scenario sc =
        rt::loadScenario(test::sourceDir() / "scenarios/rit/stlamp.toml", test::configDir());
    sc.primaryVisibility = PrimaryVisibility::kAuto;
    auto sr = rt::ScenarioRenderer::create(sc, test::dataDirs());
    SerialExecutor ex;
    const std::string note = sr->renderer().choosePrimaryVisibility(ex);
    std::printf("%s\n", note.c_str());
    const bool gl = sr->renderer().primaryByGl();
    EXPECT_EQ(note.rfind(gl ? "primary visibility gl (auto" : "primary visibility embree (auto", 0),
              0u)
        << note;
    const Renderer::PrimaryTiming t = sr->renderer().measurePrimaryPasses(ex, 1);
    EXPECT_GT(t.embree_ms, 0.0);
    std::printf("embree %.2f ms, gl %.2f ms\n", t.embree_ms, t.gl_ms);
}

// An interlaced field's own rows through the GL pass (Renderer::render with rowParity): after
// the camera moved, the even field and then the odd field give, bit for bit, the image a second
// GL renderer makes of every row at the new pose, each field casting no Embree primary ray.
TEST(GlPrimary, FieldRowsMakeTheWholeImageOfTheGlPass) {
    Pair a = openPair(test::sourceDir() / "scenarios/rit/stlamp.toml");
    if (!a.gl) GTEST_SKIP() << a.why;
    Pair b = openPair(test::sourceDir() / "scenarios/rit/stlamp.toml");
    ASSERT_TRUE(b.gl);
    const FrameSky sky = a.gl->prepare(0.0);
    (void)b.gl->prepare(0.0);
    const PinholeCamera& c = a.gl->renderer().camera();
    ImageF pa(c.width, c.height), wa(c.width, c.height), pb(c.width, c.height),
        wb(c.width, c.height);
    SerialExecutor ex;
    a.gl->renderer().render(sky, pa.view(), wa.view(), ex);
    scene::CameraPose moved = a.gl->scene().camera;
    moved.position_m = moved.position_m + Vec3{0.7, -0.4, 0.2};
    a.gl->renderer().setCamera(moved);
    b.gl->renderer().setCamera(moved);
    b.gl->renderer().render(sky, pb.view(), wb.view(), ex);
    const auto rowsSame = [&](int parity) {
        int same = 0;
        const std::size_t bytes = static_cast<std::size_t>(c.width) * sizeof(float);
        for (int y = parity; y < c.height; y += 2) {
            same += std::memcmp(pa.view().row(y), pb.view().row(y), bytes) == 0 &&
                    std::memcmp(wa.view().row(y), wb.view().row(y), bytes) == 0;
        }
        return same;
    };
    const int half = c.height / 2;
    EXPECT_LT(rowsSame(0), half / 2);  // the move changed the image
    a.gl->renderer().render(sky, pa.view(), wa.view(), ex, 0);
    EXPECT_TRUE(a.gl->renderer().primaryByGl());
    EXPECT_EQ(a.gl->renderer().lastStats().primaryRays, 0u);
    EXPECT_EQ(rowsSame(0), half);
    EXPECT_LT(rowsSame(1), half / 2);  // the odd rows still hold the old pose
    a.gl->renderer().render(sky, pa.view(), wa.view(), ex, 1);
    EXPECT_EQ(rowsSame(0), half);
    EXPECT_EQ(rowsSame(1), half);
}

}  // namespace
}  // namespace nvs::render
