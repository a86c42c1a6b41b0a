// GlVisibility (sim/render/gl_visibility.h) against an independent reference: each pixel's
// centre ray intersected with the triangles in double precision (Möller–Trumbore, the
// barycentric weights of vertices 1 and 2 and the distance), with the camera model written
// out here from docs/render.md (pixel (x, y) sampled at (x + ½, y + ½), x along right, y along
// −up, row 0 at the top). The tests skip (GTEST_SKIP, with the reasons) only when no OpenGL
// backend can be created on the machine.

#include "sim/render/gl_visibility.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "sim/core/error.h"

namespace {

using nvs::Vec3;
using nvs::render::GlBackendChoice;
using nvs::render::GlHit;
using nvs::render::GlStatus;
using nvs::render::GlView;
using nvs::render::GlVisibility;
using nvs::render::kGlMiss;

GlView testView(int w, int h) {
    GlView v;
    v.width = w;
    v.height = h;
    v.focalLength_m = 0.036;
    v.pitchX_m = 18e-6;
    v.pitchY_m = 21e-6;
    v.position_m = {1.0, -2.0, 1.5};
    // Looking north and 10° down, with 5° of twist (as Renderer::setCamera builds its frame).
    const double el = -10.0 * M_PI / 180.0, tw = 5.0 * M_PI / 180.0;
    const Vec3 fwd{0.0, std::cos(el), std::sin(el)};
    const Vec3 right0 = nvs::normalized(nvs::cross(fwd, Vec3{0, 0, 1}));
    const Vec3 up0 = nvs::cross(right0, fwd);
    v.forward = fwd;
    v.right = right0 * std::cos(tw) + up0 * std::sin(tw);
    v.up = up0 * std::cos(tw) - right0 * std::sin(tw);
    return v;
}

Vec3 pixelRay(const GlView& v, double px, double py) {
    return nvs::normalized(v.forward * v.focalLength_m +
                           v.right * ((px - 0.5 * v.width) * v.pitchX_m) -
                           v.up * ((py - 0.5 * v.height) * v.pitchY_m));
}

struct RefHit {
    bool hit = false;
    double t = 0, u = 0, v = 0, edge = 0;  // edge: smallest barycentric (distance to an edge)
};

// Möller & Trumbore (1997), "Fast, minimum storage ray-triangle intersection", in double.
RefHit intersect(const Vec3& o, const Vec3& d, const Vec3& a, const Vec3& b, const Vec3& c) {
    RefHit r;
    const Vec3 e1 = b - a, e2 = c - a, p = nvs::cross(d, e2);
    const double det = nvs::dot(e1, p);
    if (std::abs(det) < 1e-15) return r;
    const Vec3 s = o - a;
    const double u = nvs::dot(s, p) / det;
    const Vec3 q = nvs::cross(s, e1);
    const double v = nvs::dot(d, q) / det, t = nvs::dot(e2, q) / det;
    if (u < 0 || v < 0 || u + v > 1 || t <= 0) return r;
    r = {true, t, u, v, std::min({u, v, 1 - u - v})};
    return r;
}

struct Tri {
    Vec3 a, b, c;
};

// A mesh as world vertex floats and indices; every triangle has its own three vertices here
// except where a test shares them.
struct MeshData {
    std::vector<float> v;
    std::vector<std::uint32_t> idx;
    void add(const Tri& t) {
        const auto base = static_cast<std::uint32_t>(v.size() / 3);
        for (const Vec3& p : {t.a, t.b, t.c}) {
            v.push_back(static_cast<float>(p.x));
            v.push_back(static_cast<float>(p.y));
            v.push_back(static_cast<float>(p.z));
        }
        idx.insert(idx.end(), {base, base + 1, base + 2});
    }
};

std::unique_ptr<GlVisibility> makeOrSkip(GlBackendChoice choice, int w, int h, std::string* why) {
    return GlVisibility::create(choice, w, h, why);
}

#define NVS_GL_OR_SKIP(var, w, h)                                                    \
    std::string why_;                                                                \
    auto var = makeOrSkip(GlBackendChoice::kAuto, w, h, &why_);                      \
    if (!(var)) GTEST_SKIP() << "no OpenGL backend on this machine: " << why_;       \
    std::printf("GL backend %s: %s\n", nvs::render::glBackendName((var)->backend()), \
                (var)->description().c_str())

}  // namespace

TEST(GlVisibility, EachBackendLoadsOrSaysWhy) {
    int made = 0;
    for (GlBackendChoice c : {GlBackendChoice::kEglDevice, GlBackendChoice::kEglSurfaceless,
                              GlBackendChoice::kOsMesa}) {
        std::string why;
        auto v = GlVisibility::create(c, 64, 48, &why);
        if (v) {
            ++made;
            std::printf("%s: %s\n", nvs::render::glBackendName(v->backend()),
                        v->description().c_str());
            EXPECT_TRUE(why.empty());
        } else {
            std::printf("not available: %s\n", why.c_str());
            EXPECT_FALSE(why.empty());
            EXPECT_EQ(why.find('\n'), std::string::npos);
        }
    }
    if (made == 0) GTEST_SKIP() << "no OpenGL backend on this machine";
}

// Two triangles (a quad's halves, shared vertices, indexed) and a third triangle in front of
// part of them: geomId, primId, u, v, t per pixel against the double-precision reference.
TEST(GlVisibility, MatchesRayTriangleReferencePerPixel) {
    constexpr int kW = 160, kH = 120;
    NVS_GL_OR_SKIP(gl, kW, kH);
    const GlView view = testView(kW, kH);
    // geom 3: a wall 20 m north, two triangles over shared corners; geom 7: a slanted panel.
    const Vec3 w0{-6, 18, -1}, w1{8, 18, -1}, w2{8, 19, 6}, w3{-6, 19, 6};
    const std::vector<float> wallV = {-6, 18, -1, 8, 18, -1, 8, 19, 6, -6, 19, 6};
    const std::vector<std::uint32_t> wallI = {0, 1, 2, 0, 2, 3};
    const Tri panel{{-1, 6, 0}, {2.5, 7, 0.2}, {0.5, 8, 3}};
    MeshData pm;
    pm.add(panel);
    gl->addMesh(wallV.data(), 4, wallI.data(), 2, 3);
    gl->addMesh(pm.v.data(), 3, pm.idx.data(), 1, 7);
    ASSERT_EQ(gl->render(view), GlStatus::kOk);
    const Tri tris[3] = {{w0, w1, w2}, {w0, w2, w3}, panel};
    const std::uint32_t geom[3] = {3, 3, 7}, prim[3] = {0, 1, 0};
    int checked = 0, edge = 0, hits = 0;
    double worstUv = 0, worstT = 0;
    for (int y = 0; y < kH; ++y) {
        for (int x = 0; x < kW; ++x) {
            const Vec3 d = pixelRay(view, x + 0.5, y + 0.5);
            RefHit best;
            int bi = -1;
            for (int k = 0; k < 3; ++k) {
                const RefHit r = intersect(view.position_m, d, tris[k].a, tris[k].b, tris[k].c);
                if (r.hit && (bi < 0 || r.t < best.t)) best = r, bi = k;
            }
            const GlHit g = gl->hit(x, y);
            // Pixel centres within 10⁻⁴ (barycentric) of an edge may go either way.
            if (bi >= 0 && best.edge < 1e-4) {
                ++edge;
                continue;
            }
            ++checked;
            if (bi < 0) {
                EXPECT_EQ(g.geomId, kGlMiss) << x << "," << y;
                continue;
            }
            ++hits;
            ASSERT_EQ(g.geomId, geom[bi]) << x << "," << y;
            ASSERT_EQ(g.primId, prim[bi]) << x << "," << y;
            worstUv = std::max({worstUv, std::abs(g.u - best.u), std::abs(g.v - best.v)});
            worstT = std::max(worstT, std::abs(g.t_m - best.t) / best.t);
        }
    }
    std::printf("%d pixels checked (%d hits), %d on edges; worst |Δu|,|Δv| %.2g, worst Δt/t %.2g\n",
                checked, hits, edge, worstUv, worstT);
    EXPECT_GT(hits, kW * kH / 4);
    EXPECT_LT(edge, kW * kH / 100);
    // GL decides which triangle; the point on it is computed in double (gl_visibility.h).
    EXPECT_LT(worstUv, 1e-9);
    EXPECT_LT(worstT, 1e-9);
}

// Reversed-Z float depth: two parallel planes 1 cm apart at 1 km; the nearer is seen at every
// pixel, whichever is drawn first.
TEST(GlVisibility, ResolvesOneCentimetreAtOneKilometre) {
    constexpr int kW = 64, kH = 48;
    NVS_GL_OR_SKIP(gl, kW, kH);
    const GlView view = testView(kW, kH);
    const auto plane = [&](double dy) {
        // A square 1 km ahead along the view direction, facing the camera.
        const Vec3 c = view.position_m + view.forward * (1000.0 + dy);
        const Vec3 r = view.right * 200.0, u = view.up * 200.0;
        const Vec3 p[4] = {c - r - u, c + r - u, c + r + u, c - r + u};
        std::vector<float> v;
        for (const Vec3& q : p)
            v.insert(v.end(),
                     {static_cast<float>(q.x), static_cast<float>(q.y), static_cast<float>(q.z)});
        return v;
    };
    const std::vector<std::uint32_t> idx = {0, 1, 2, 0, 2, 3};
    const std::vector<float> farV = plane(0.01), nearV = plane(0.0);
    gl->addMesh(farV.data(), 4, idx.data(), 2, 1);   // drawn first
    gl->addMesh(nearV.data(), 4, idx.data(), 2, 2);  // nearer, drawn second
    const std::vector<float> farV2 = plane(0.0), nearV2 = plane(0.01);
    ASSERT_EQ(gl->render(view), GlStatus::kOk);
    int nearSeen = 0;
    for (int y = 0; y < kH; ++y)
        for (int x = 0; x < kW; ++x)
            nearSeen += gl->hit(x, y).geomId == 2u ? 1 : 0;
    EXPECT_EQ(nearSeen, kW * kH);
    // Swap them (the nearer now drawn first): per-frame vertex updates.
    ASSERT_EQ(gl->setVertices(0, farV2.data()), GlStatus::kOk);
    ASSERT_EQ(gl->setVertices(1, nearV2.data()), GlStatus::kOk);
    ASSERT_EQ(gl->render(view), GlStatus::kOk);
    int firstSeen = 0;
    double worstT = 0;
    for (int y = 0; y < kH; ++y) {
        for (int x = 0; x < kW; ++x) {
            const GlHit g = gl->hit(x, y);
            firstSeen += g.geomId == 1u ? 1 : 0;
            const Vec3 d = pixelRay(view, x + 0.5, y + 0.5);
            worstT = std::max(worstT, std::abs(g.t_m - 1000.0 / nvs::dot(d, view.forward)));
        }
    }
    EXPECT_EQ(firstSeen, kW * kH);
    std::printf("worst |Δt| at 1 km: %.3g m\n", worstT);
    EXPECT_LT(worstT, 2e-3);
}

// A rectangle re-rendered leaves the pixels outside it as they were; a disabled mesh is not
// drawn; a rectangle outside the image is refused.
TEST(GlVisibility, RectangleAndDisabledMesh) {
    constexpr int kW = 64, kH = 48;
    NVS_GL_OR_SKIP(gl, kW, kH);
    const GlView view = testView(kW, kH);
    const Vec3 c = view.position_m + view.forward * 10.0;
    const Vec3 r = view.right * 50.0, u = view.up * 50.0;
    MeshData m;
    m.add({c - r - u, c + r - u, c + r + u});
    m.add({c - r - u, c + r + u, c - r + u});
    const int h = gl->addMesh(m.v.data(), 6, m.idx.data(), 2, 0);
    ASSERT_EQ(gl->render(view), GlStatus::kOk);
    gl->setEnabled(h, false);
    ASSERT_EQ(gl->render(view, 10, 5, 30, 20), GlStatus::kOk);
    for (int y = 0; y < kH; ++y) {
        for (int x = 0; x < kW; ++x) {
            const bool inside = x >= 10 && x < 30 && y >= 5 && y < 20;
            ASSERT_EQ(gl->hit(x, y).geomId, inside ? kGlMiss : 0u) << x << "," << y;
        }
    }
    EXPECT_EQ(gl->render(view, 0, 0, kW + 1, kH), GlStatus::kBadRect);
    EXPECT_THROW(gl->addMesh(m.v.data(), 2, m.idx.data(), 2, 0), nvs::SetupError);
}

// Every software backend present (EGL surfaceless, OSMesa) gives the same answer.
TEST(GlVisibility, BackendsAgree) {
    constexpr int kW = 96, kH = 64;
    std::string why1, why2;
    auto a = GlVisibility::create(GlBackendChoice::kEglSurfaceless, kW, kH, &why1);
    auto b = GlVisibility::create(GlBackendChoice::kOsMesa, kW, kH, &why2);
    if (!a || !b) GTEST_SKIP() << "needs both EGL surfaceless and OSMesa: " << why1 << why2;
    const GlView view = testView(kW, kH);
    MeshData m;
    m.add({{-3, 9, -1}, {4, 12, 0}, {0, 10, 4}});
    m.add({{-5, 14, -1}, {6, 15, -1}, {1, 16, 5}});
    for (auto* g : {a.get(), b.get()}) {
        g->addMesh(m.v.data(), 6, m.idx.data(), 2, 5);
        ASSERT_EQ(g->render(view), GlStatus::kOk);
    }
    int differ = 0;
    for (int y = 0; y < kH; ++y) {
        for (int x = 0; x < kW; ++x) {
            const GlHit p = a->hit(x, y), q = b->hit(x, y);
            differ += (p.geomId != q.geomId || p.primId != q.primId ||
                       std::abs(p.t_m - q.t_m) > 1e-9 * p.t_m)
                          ? 1
                          : 0;
        }
    }
    EXPECT_EQ(differ, 0);
}
