// Ground truth of the tracked objects (issue 31, docs/contracts.md "meta:"): the visible fraction
// against a measure that does not use the truth's sample rays — the object's pixels in the
// primary-visibility G-buffer with every object in the scene, over its pixels with the other
// objects switched off —, truncation at the image's edge, and per-field boxes of an interlaced
// frame that differ by the motion over one field.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "rt/compose/scene_setup.h"
#include "rt/loop/frame_loop.h"
#include "rt/render_stage/render_stage.h"
#include "rt/synth/synth.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::rt {
namespace {

const std::filesystem::path kDrive =
    std::filesystem::path(NVS_SOURCE_DIR) / "scenarios" / "vehicle-drive" / "scenario.toml";

int objectIndex(const scene::Scene& s, const char* name) {
    for (std::size_t i = 0; i < s.objects.size(); ++i)
        if (s.objects[i].name == name) return static_cast<int>(i);
    return -1;
}

// The G-buffer's pixels whose primary hit is object `obj`.
int pixelsOf(const render::Renderer& r, int obj) {
    int n = 0;
    for (int y = 0; y < r.camera().height; ++y) {
        for (int x = 0; x < r.camera().width; ++x) {
            Vec3 p;
            int m = -1, o = -1;
            if (r.pixelHit(x, y, &p, &m, &o) && o == obj) ++n;
        }
    }
    return n;
}

const render::Renderer::ObjectTruth* find(const render::Renderer::ObjectTruth* t, int n, int id) {
    for (int i = 0; i < n; ++i)
        if (t[i].id == id) return &t[i];
    return nullptr;
}

// vehicle-drive's renderer, and one measurement: the truth of the frame at `sky` as it is, and the
// person's pixels in the G-buffer with every object and with the person alone.
struct Drive {
    std::unique_ptr<ScenarioRenderer> sr = ScenarioRenderer::create(kDrive, test::dataDirs(), 1);
    render::Renderer& r = sr->renderer();
    render::SerialExecutor exec;
    ImageF pe{r.camera().width, r.camera().height}, band{r.camera().width, r.camera().height};
    int person = objectIndex(sr->scene(), "person");
    render::Renderer::ObjectTruth truth[kMaxTruthBoxes];
    int truthCount = 0, seen = 0, own = 0;
    double truth_s = 0.0;  // the truthBoxes call's wall time

    const render::Renderer::ObjectTruth* measure(const FrameSky& sky) {
        const auto enable = [&](bool others) {
            for (std::size_t o = 0; o < sr->scene().objects.size(); ++o)
                r.setObjectEnabled(static_cast<int>(o), others || static_cast<int>(o) == person);
        };
        enable(true);
        r.render(sky, pe.view(), band.view(), exec);
        const auto t0 = std::chrono::steady_clock::now();
        truthCount = r.truthBoxes(truth, kMaxTruthBoxes);
        truth_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        seen = pixelsOf(r, person);
        enable(false);
        r.render(sky, pe.view(), band.view(), exec);
        own = pixelsOf(r, person);
        enable(true);
        return find(truth, truthCount, 2);
    }
};

// vehicle-drive: the truck (track 1) drives across the lot between the roof camera and the
// person (track 2). Frames 30 … 59 (t = k/29.97 s): the person's visible fraction from the truth
// against seen pixels / own pixels of the G-buffer. The truck hides all of the person but the top
// of the head (1.72–1.75 m up, over the truck's 1.72-m roof, seen from the 15-m-high roof: 126 of
// the person's 1934 pixels at frames 45–46), then the person emerges, never receding on the way.
TEST(Truth, PersonBehindThePassingTruckIsHiddenAndEmerges) {
    Drive d;
    ASSERT_GE(d.person, 0);
    std::vector<double> vis, pix;
    for (int k = 30; k < 60; ++k) {
        const render::Renderer::ObjectTruth* p = d.measure(d.sr->prepare(k / 29.97));
        const int seen = d.seen, own = d.own;
        ASSERT_NE(p, nullptr) << "frame " << k;
        EXPECT_STREQ(p->cls, "person");
        ASSERT_GT(own, 100) << "frame " << k;
        vis.push_back(p->visible);
        pix.push_back(static_cast<double>(seen) / own);
        std::printf(
            "frame %d: person visible %.3f (truth), %.3f (G-buffer: %d of %d px), range "
            "%.2f m%s; the truth of %d objects took %.2f ms\n",
            k, static_cast<double>(p->visible), pix.back(), seen, own,
            static_cast<double>(p->range_m), p->truncated ? ", truncated" : "", d.truthCount,
            d.truth_s * 1e3);
        EXPECT_NEAR(vis.back(), pix.back(), 0.08) << "frame " << k;
    }
    // Whole at first, nearly hidden, then out again, never receding on the way out.
    EXPECT_EQ(vis.front(), 1.0);
    const auto least = std::min_element(vis.begin(), vis.end());
    EXPECT_LT(*least, 0.1);
    EXPECT_GT(vis.back(), 0.95);
    for (auto it = least; it + 1 != vis.end(); ++it)
        EXPECT_GE(*(it + 1), *it - 0.02) << "frame " << 30 + (it - vis.begin());
    const bool partly =
        std::any_of(vis.begin(), vis.end(), [](double v) { return v > 0.1 && v < 0.9; });
    EXPECT_TRUE(partly) << "no frame with the person partly hidden";
}

// Wholly hidden: at frame 45, a camera 1.2 m above the lot, 5 m beyond the truck on the line from
// the person through the truck, looking at the person. The truck's body (0.4–1.1 m) and cabin
// (to 1.72 m) cover all of the person: the truth says 0 and so does the G-buffer.
TEST(Truth, APersonWhollyBehindTheTruckIsZeroVisible) {
    Drive d;
    const double t = 45 / 29.97;
    const FrameSky sky = d.sr->prepare(t);
    const int truck = objectIndex(d.sr->scene(), "truck");
    Vec3 pp, tp;
    double yaw = 0.0;
    d.sr->scene().objects[static_cast<std::size_t>(d.person)].poseAt(t, &pp, &yaw);
    d.sr->scene().objects[static_cast<std::size_t>(truck)].poseAt(t, &tp, &yaw);
    Vec3 away = tp - pp;
    away.z = 0.0;
    away = normalized(away);
    scene::CameraPose pose;
    pose.position_m = tp + away * 5.0;
    pose.position_m.z = 1.2;
    pose.target_m = Vec3{pp.x, pp.y, 0.9};
    d.r.setCamera(pose);
    const render::Renderer::ObjectTruth* p = d.measure(sky);
    const int seen = d.seen, own = d.own;
    ASSERT_NE(p, nullptr);
    std::printf("behind the truck: person visible %.3f (truth), %d of %d px in the G-buffer\n",
                static_cast<double>(p->visible), seen, own);
    ASSERT_GT(own, 100);
    EXPECT_EQ(seen, 0);
    EXPECT_EQ(p->visible, 0.0f);
}

// A box at the image's edge is marked truncated, one inside it is not: the truck enters from the
// edge (frame 0) and the person stands inside the image.
TEST(Truth, ABoxCutByTheImageEdgeIsTruncated) {
    auto sr = ScenarioRenderer::create(kDrive, test::dataDirs(), 1);
    render::Renderer& r = sr->renderer();
    render::SerialExecutor exec;
    const int W = r.camera().width, H = r.camera().height;
    ImageF pe(W, H), band(W, H);
    render::Renderer::ObjectTruth truth[kMaxTruthBoxes];
    int edge = 0, inside = 0;
    for (int k = 0; k < 60; k += 3) {
        r.render(sr->prepare(k / 29.97), pe.view(), band.view(), exec);
        const int n = r.truthBoxes(truth, kMaxTruthBoxes);
        for (int i = 0; i < n; ++i) {
            const render::Renderer::ObjectTruth& b = truth[i];
            const bool atEdge = b.x_px <= 0.0f || b.y_px <= 0.0f ||
                                b.x_px + b.w_px >= static_cast<float>(W) ||
                                b.y_px + b.h_px >= static_cast<float>(H);
            EXPECT_EQ(b.truncated, atEdge) << "frame " << k << " id " << b.id << " box " << b.x_px
                                           << " " << b.y_px << " " << b.w_px << " " << b.h_px;
            (atEdge ? edge : inside) += 1;
        }
    }
    EXPECT_GT(edge, 0) << "no box at the edge";
    EXPECT_GT(inside, 0);
}

// Each field of an interlaced frame carries its own truth: vehicle-drive at 29.97 frames/s
// interlaced (fields 16.7 ms apart), through the frame loop under the sim clock. The truck at
// 9 m/s moves between the fields; its box shifts by half of what it shifts from one frame to the
// next (the motion is steady), and the frame-level truth is field 1's. (The box's x centre is
// compared where its sides lie inside the image; the bottom edge cuts it throughout.)
class MetaRecorder final : public FrameSink {
  public:
    const char* name() const noexcept override { return "meta-recorder"; }
    int write(const OutputFrame& f) noexcept override {
        if (!f.repeat && n < kMax) metas[n++] = *f.meta;
        return 0;
    }
    int close() noexcept override { return 0; }
    std::string status() const override { return "recorder"; }
    static constexpr int kMax = 60;
    FrameMeta metas[kMax];
    int n = 0;
};

TEST(Truth, FieldsOfAnInterlacedFrameCarryTheirOwnBoxes) {
    Scenario sc = loadScenario(kDrive, test::configDir());
    sc.scan = ScanKind::Interlaced;
    sc.renderCoarse = 4;  // the boxes do not depend on the pixels
    auto render = SceneRenderStage::create(sc, test::dataDirs());
    LinearCamera camera(1000.0, 16);
    auto rec = std::make_unique<MetaRecorder>();  // 60 frames' metadata: on the heap
    HeldPlatform platform(sc.platform);
    LoopConfig cfg;
    cfg.rate = sc.rate;
    cfg.clock = ClockKind::Sim;
    cfg.frames = 60;
    cfg.width = sc.width;
    cfg.height = sc.height;
    cfg.scan = ScanKind::Interlaced;
    FrameLoop loop(cfg, platform, *render, camera, {rec.get()});
    std::vector<std::string> messages;
    loop.start(messages);
    loop.join();
    ASSERT_EQ(rec->n, 60);
    const auto truck = [](const FieldMeta& f) -> const TruthBox* {
        for (int i = 0; i < f.truthCount; ++i)
            if (f.truth[i].id == 1) return &f.truth[i];
        return nullptr;
    };
    int checked = 0;
    for (int k = 0; k + 1 < rec->n; ++k) {
        const FrameMeta& m = rec->metas[k];
        ASSERT_EQ(m.fieldCount, 2);
        EXPECT_NEAR(m.field[1].t_sample_s - m.field[0].t_sample_s, 1001.0 / 60000.0, 1e-9);
        const TruthBox* a = truck(m.field[0]);
        const TruthBox* b = truck(m.field[1]);
        const TruthBox* next = truck(rec->metas[k + 1].field[1]);
        // The truck's box is cut by the image's bottom edge all the way (truncated); its x
        // extent is whole where it lies inside the image's sides.
        const auto xWhole = [&](const TruthBox* t) {
            return t != nullptr && t->x_px > 0.0f &&
                   t->x_px + t->w_px < static_cast<float>(sc.width);
        };
        if (!xWhole(a) || !xWhole(b) || !xWhole(next)) continue;
        // The frame-level truth is field 1's.
        ASSERT_EQ(m.truthCount, m.field[1].truthCount);
        const float cx0 = a->x_px + 0.5f * a->w_px, cx1 = b->x_px + 0.5f * b->w_px;
        const float cxNext = next->x_px + 0.5f * next->w_px;
        const double field = cx1 - cx0, frame = cxNext - cx1;
        std::printf(
            "frame %d: truck box centre %.2f → %.2f px over a field, %.2f px over a frame\n", k,
            static_cast<double>(cx0), static_cast<double>(cx1), frame);
        EXPECT_GT(std::fabs(field), 1.0) << "frame " << k;
        EXPECT_NEAR(field, 0.5 * frame, 0.1 * std::fabs(frame) + 0.05) << "frame " << k;
        ++checked;
    }
    EXPECT_GE(checked, 4);
}

// The camera's geometry in the metadata (msg::CameraGeometry, docs/contracts.md) puts every
// primary hit of the G-buffer back on its own pixel centre: K·(R·X + t) with X the hit in the
// scene frame. The scene's own camera (vehicle-drive) and a pose from telemetry, turned and
// pitched down over the RIT site (the airborne pass's scene).
TEST(CameraGeometry, ProjectsTheGBuffersHitsToTheirPixelCentres) {
    const std::filesystem::path air =
        std::filesystem::path(NVS_SOURCE_DIR) / "scenarios" / "airborne-pass" / "scenario.toml";
    for (const std::filesystem::path& file : {kDrive, air}) {
        Scenario sc = loadScenario(file, test::configDir());
        sc.renderCoarse = 4;
        auto stage = SceneRenderStage::create(sc, test::dataDirs());
        const int W = sc.width, H = sc.height;
        ImageF pe(W, H), band(W, H);
        FrameRequest req;
        req.t_sample_s = 0.5;
        req.platform = sc.platform;
        req.platform.lampMask = stage->initialLampMask();
        if (file == air) {
            const auto& site = stage->scenario().scenario().scene.site;
            req.platform.poseFromTelemetry = true;
            req.platform.lat_deg = site.lat_deg + 0.004;
            req.platform.lon_deg = site.lon_deg - 0.003;
            req.platform.alt_m = site.height_m + 600.0;
            req.platform.yaw_rad = 2.6;
            req.platform.pitch_rad = -0.5;
            req.platform.roll_rad = 0.05;
        }
        FrameMeta meta;
        stage->render(req, RadianceTarget{pe.view(), band.view()}, meta);
        const msg::CameraGeometry& g = meta.camera;
        ASSERT_TRUE(g.valid);
        EXPECT_EQ(g.width, W);
        EXPECT_EQ(g.height, H);
        const render::Renderer& r = stage->scenario().renderer();
        double worst = 0.0;
        int hits = 0;
        for (int y = 3; y < H; y += 17) {
            for (int x = 5; x < W; x += 23) {
                Vec3 X;
                int m = -1, o = -1;
                if (!r.pixelHit(x, y, &X, &m, &o)) continue;
                double c[3];
                for (int i = 0; i < 3; ++i)
                    c[i] =
                        g.R[3 * i] * X.x + g.R[3 * i + 1] * X.y + g.R[3 * i + 2] * X.z + g.t_m[i];
                ASSERT_GT(c[2], 0.0);
                const double u = g.fx_px * c[0] / c[2] + g.cx_px;
                const double v = g.fy_px * c[1] / c[2] + g.cy_px;
                worst = std::max({worst, std::fabs(u - (x + 0.5)), std::fabs(v - (y + 0.5))});
                ++hits;
            }
        }
        std::printf("%s: %d hits projected, worst %.4f px from their pixel centres\n",
                    file.parent_path().filename().c_str(), hits, worst);
        EXPECT_GT(hits, 500);
        EXPECT_LT(worst, 0.01);
        // R is a rotation.
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                const double d = g.R[3 * i] * g.R[3 * j] + g.R[3 * i + 1] * g.R[3 * j + 1] +
                                 g.R[3 * i + 2] * g.R[3 * j + 2];
                EXPECT_NEAR(d, i == j ? 1.0 : 0.0, 1e-12);
            }
        }
    }
}

}  // namespace
}  // namespace nvs::rt
