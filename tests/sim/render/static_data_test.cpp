// The renderer keeps what depends only on the geometry, the camera and the lamps' placement
// (G-buffer, lamp factors, specular hits, upsampling weights) from frame to frame. Whatever
// changes in between — a lamp switched on, the terms asked for, an object taken out and put
// back, the coarse factor, the camera — the image must be bit for bit the one a fresh renderer
// gives for the same state.

#include <gtest/gtest.h>
#include <unistd.h>

#include <cstring>
#include <filesystem>
#include <fstream>

#include "rt/compose/scene_setup.h"
#include "sim/render/renderer.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::render {
using rt::renderConfigFor;
using rt::ScenarioRenderer;
namespace {

struct Frame {
    ImageF pe{768, 494}, w{768, 494};
};

bool same(const Frame& a, const Frame& b) {
    for (int y = 0; y < 494; ++y) {
        if (std::memcmp(a.pe.view().row(y), b.pe.view().row(y), 768 * sizeof(float)) != 0 ||
            std::memcmp(a.w.view().row(y), b.w.view().row(y), 768 * sizeof(float)) != 0) {
            return false;
        }
    }
    return true;
}

TEST(StaticData, ReusedStateGivesTheImageOfAFreshRenderer) {
    const auto path = test::sourceDir() / "scenarios/rit/stlamp.toml";
    auto a = ScenarioRenderer::create(path, test::dataDirs(), 4);
    auto b = ScenarioRenderer::create(path, test::dataDirs(), 4);
    const FrameSky sky = a->prepare(0.0);
    (void)b->prepare(0.0);
    const int lamp = a->scene().lampIndex("street_lamp");
    ASSERT_GE(lamp, 0);
    SerialExecutor ex;
    Frame fa, fb;
    for (int f : {1, 4}) {
        a->renderer().setCoarseFactor(f);
        b->renderer().setCoarseFactor(f);
        // Lamp off for a frame, then on: as a renderer that always had it on.
        a->renderer().setLampOn(lamp, false);
        a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
        a->renderer().setLampOn(lamp, true);
        a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
        b->renderer().render(sky, fb.pe.view(), fb.w.view(), ex);
        EXPECT_TRUE(same(fa, fb)) << "lamp switched on, f = " << f;
        // Only the Moon's term for a frame, then all.
        a->renderer().setTerms(kTermMoon);
        a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
        a->renderer().setTerms(kTermAll);
        a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
        EXPECT_TRUE(same(fa, fb)) << "terms, f = " << f;
        // An object out for a frame, then back.
        a->renderer().setObjectEnabled(0, false);
        a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
        a->renderer().setObjectEnabled(0, true);
        a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
        EXPECT_TRUE(same(fa, fb)) << "object, f = " << f;
        // The camera elsewhere for a frame, then back.
        scene::CameraPose p = a->scene().camera;
        p.target_m = p.target_m + Vec3{3.0, 0.0, 0.0};
        a->renderer().setCamera(p);
        a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
        a->renderer().setCamera(a->scene().camera);
        a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
        EXPECT_TRUE(same(fa, fb)) << "camera, f = " << f;
    }
    // Coarse factor 2 after 4 and 1: as fresh.
    a->renderer().setCoarseFactor(2);
    a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
    auto c = ScenarioRenderer::create(path, test::dataDirs(), 4);
    (void)c->prepare(0.0);
    c->renderer().setCoarseFactor(2);
    c->renderer().render(sky, fb.pe.view(), fb.w.view(), ex);
    EXPECT_TRUE(same(fa, fb)) << "coarse factor 2";
}

// A truck crossing the lot under the fixed camera, the street lamp on (its shadows move with
// the truck) and the asphalt specular (the truck shows in its reflections): the renderer redoes
// only the pixels the truck's old and new bounds cover and the static data of rays that cross
// them, and every frame must be bit for bit the one a fresh renderer gives at that time.
TEST(StaticData, MovingObjectGivesTheImageOfAFreshRenderer) {
    // A folder of this process's own: the test program may run twice at once (ctest's
    // isa.native.* entries run it with each Embree kernel set).
    const auto dir = std::filesystem::temp_directory_path() /
                     ("nvs_static_moving-" + std::to_string(::getpid()));
    std::filesystem::create_directories(dir);
    const auto path = dir / "drive_lamp.toml";
    std::ofstream(path) << "[scenario]\nname = \"drive-lamp\"\n"
                           "utc_start = \"1998-09-02T04:30:00Z\"\nframe_rate_hz = 29.97\n"
                           "width = 768\nheight = 494\n"
                           "[site]\nlat_deg = 43.16856\nlon_deg = -77.61583\nheight_m = 218.0\n"
                           "[atmosphere]\nvisibility_km = 23.0\naerosol = \"rural\"\n"
                           "[camera]\npreset = \"pulnix-ag5745ef3\"\n"
                           "[scene]\nfile = \""
                        << (test::sourceDir() / "scenarios/rit/scene_drive.toml").string()
                        << "\"\nlamps_on = [\"street_lamp\"]\n";
    SerialExecutor ex;
    Frame fa, fb;
    for (int f : {1, 4}) {
        auto a = ScenarioRenderer::create(path, test::dataDirs(), 4);
        a->renderer().setCoarseFactor(f);
        std::uint64_t fullPrimary = 0;
        for (double t : {0.0, 0.5, 0.6, 1.4}) {
            const FrameSky sky = a->prepare(t);
            a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
            const std::uint64_t primary = a->renderer().lastStats().primaryRays;
            if (t == 0.0) {
                fullPrimary = primary;
            } else {
                // Only a part of the image was cast again.
                EXPECT_GT(primary, 0u) << t;
                EXPECT_LT(primary, fullPrimary / 2) << t;
            }
            auto b = ScenarioRenderer::create(path, test::dataDirs(), 4);
            b->renderer().setCoarseFactor(f);
            const FrameSky skyB = b->prepare(t);
            b->renderer().render(skyB, fb.pe.view(), fb.w.view(), ex);
            EXPECT_TRUE(same(fa, fb)) << "t = " << t << " s, f = " << f;
        }
    }
    std::filesystem::remove_all(dir);
}

// An interlaced field's own rows (render with rowParity): after the camera moved, rendering
// the even rows gives exactly a fresh renderer's even rows at the new pose and leaves the odd
// rows as they were, casting only half the primary rays; the odd rows rendered next (camera
// unchanged) complete exactly the fresh renderer's image.
TEST(StaticData, AFieldRendersItsOwnRowsOnlyAndTheirUnionIsTheWholeImage) {
    const auto path = test::sourceDir() / "scenarios/rit/stlamp.toml";
    auto a = ScenarioRenderer::create(path, test::dataDirs(), 1);
    auto b = ScenarioRenderer::create(path, test::dataDirs(), 1);
    const FrameSky sky = a->prepare(0.0);
    (void)b->prepare(0.0);
    SerialExecutor ex;
    Frame fa, fb, before;
    a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex);
    const std::uint64_t fullPrimary = a->renderer().lastStats().primaryRays;
    before.pe = fa.pe;
    before.w = fa.w;
    scene::CameraPose moved = a->scene().camera;
    moved.position_m = moved.position_m + Vec3{0.7, -0.4, 0.2};
    a->renderer().setCamera(moved);
    b->renderer().setCamera(moved);
    b->renderer().render(sky, fb.pe.view(), fb.w.view(), ex);
    a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex, 0);
    EXPECT_EQ(a->renderer().lastStats().primaryRays, fullPrimary / 2);
    const std::size_t rowBytes = 768 * sizeof(float);
    int evenSame = 0, oddKept = 0, evenChanged = 0;
    for (int y = 0; y < 494; ++y) {
        const bool asFresh = std::memcmp(fa.pe.view().row(y), fb.pe.view().row(y), rowBytes) == 0 &&
                             std::memcmp(fa.w.view().row(y), fb.w.view().row(y), rowBytes) == 0;
        const bool asBefore =
            std::memcmp(fa.pe.view().row(y), before.pe.view().row(y), rowBytes) == 0 &&
            std::memcmp(fa.w.view().row(y), before.w.view().row(y), rowBytes) == 0;
        if (y % 2 == 0) {
            evenSame += asFresh;
            evenChanged += !asBefore;
        } else {
            oddKept += asBefore;
        }
    }
    EXPECT_EQ(evenSame, 247);
    EXPECT_EQ(oddKept, 247);
    EXPECT_GT(evenChanged, 200);  // the move changed the image (the test can see a stale row)
    a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex, 1);
    EXPECT_EQ(a->renderer().lastStats().primaryRays, fullPrimary / 2);
    EXPECT_TRUE(same(fa, fb));
    // Both parities valid now: a field of either parity casts no primary ray and stays exact.
    a->renderer().render(sky, fa.pe.view(), fa.w.view(), ex, 0);
    EXPECT_EQ(a->renderer().lastStats().primaryRays, 0u);
    EXPECT_TRUE(same(fa, fb));
}

}  // namespace
}  // namespace nvs::render
