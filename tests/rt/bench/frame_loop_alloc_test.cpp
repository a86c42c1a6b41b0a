// The frame loop allocates nothing per field in steady state (docs/style.md §3; issue 17): the
// rendered airborne pass (moving platform from its CAN log, 768×494 interlaced, every camera stage,
// y4m and metadata outputs) under the sim clock, with the global operator new replaced by a
// counting one (rt/bench/count_new.cpp, linked into this test). The count is read from the
// render thread when it samples the pose of field 20 (frame 10: setup and the pipeline's fill
// are over) and of field 60; in between every thread of the loop — render, camera, output and
// the sinks' — ran 40 fields.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "rt/bench/alloc_count.h"
#include "rt/camera_stage/bolometer_stage.h"
#include "rt/camera_stage/camera_stage.h"
#include "rt/compose/scenario.h"
#include "rt/loop/frame_loop.h"
#include "rt/render_stage/render_stage.h"
#include "rt/run/run.h"

namespace nvs::rt {
namespace {

// Passes every sample on and notes the allocation count at two sample numbers.
class CountingPlatform final : public PlatformSource {
  public:
    CountingPlatform(PlatformSource& inner, int from, int to)
        : inner_(inner), from_(from), to_(to) {}
    void sample(double t_sample_s, double now_s, PlatformState& out) noexcept override {
        if (calls_ == from_) atFrom = bench::allocationCount();
        if (calls_ == to_) atTo = bench::allocationCount();
        ++calls_;
        inner_.sample(t_sample_s, now_s, out);
    }
    std::string status() const override { return inner_.status(); }
    std::uint64_t atFrom = 0, atTo = 0;

  private:
    PlatformSource& inner_;
    int from_, to_;
    int calls_ = 0;
};

TEST(FrameLoopAllocations, TheCounterSeesEveryFormOfNewOnAnyThread) {
    if (!bench::allocationCounting()) GTEST_SKIP() << "operator new is not replaced";
    const std::uint64_t a0 = bench::allocationCount();
    std::thread t([] {
        auto a = std::make_unique<int>(1);                  // new
        auto b = std::make_unique<double[]>(4);             // new[]
        std::unique_ptr<ImageF> c(new ImageF(8, 8));        // new + aligned new[] (its pixels)
        std::unique_ptr<int> d(new (std::nothrow) int(2));  // nothrow new
    });
    t.join();
    // The thread's own start (its state block) is one more operator new in libstdc++.
    EXPECT_GE(bench::allocationCount() - a0, 5u);
    EXPECT_LE(bench::allocationCount() - a0, 6u);
}

// Runs `frames` frames of `sc` under the sim clock through `render` and `camera` to y4m and
// metadata sinks, and checks that the samples fromSample … toSample of the platform (fields of
// an interlaced scan, frames of a progressive one) saw no operator new; setup did allocate.
void expectNoneInSteadyState(const Scenario& sc, PlatformSource& platform, RenderStage& render,
                             CameraStage& camera, int frames, int fromSample, int toSample,
                             const char* unit) {
    CountingPlatform counting(platform, fromSample, toSample);
    auto y4m = makeSink("y4m:/dev/null", sc, frames);
    // Each test its own file: ctest runs the tests of this binary as processes side by side.
    const std::string metaPath =
        ::testing::TempDir() + "frame_loop_alloc_meta_" + std::to_string(::getpid()) + ".jsonl";
    auto meta = makeSink("meta:" + metaPath, sc, frames);
    LoopConfig cfg;
    cfg.rate = sc.rate;
    cfg.clock = ClockKind::Sim;
    cfg.frames = frames;
    cfg.exposure_s = sc.exposure_s;
    cfg.width = sc.width;
    cfg.height = sc.height;
    cfg.scan = sc.scan;
    cfg.topFieldFirst = sc.fieldOrder() != msg::FieldOrder::BottomFirst;
    FrameLoop loop(cfg, counting, render, camera, {y4m.get(), meta.get()});
    std::vector<std::string> messages;
    loop.start(messages);
    loop.join();
    ASSERT_EQ(loop.failure(), "");
    ASSERT_EQ(loop.stats().counters.framesEmitted, frames);
    ASSERT_GT(counting.atTo, 0u);
    EXPECT_EQ(y4m->close(), 0);
    EXPECT_EQ(meta->close(), 0);
    std::filesystem::remove(metaPath);
    // The counter itself counts: setup allocated (the scene, the images, the tables).
    EXPECT_GT(counting.atFrom, 1000u);
    EXPECT_EQ(counting.atTo - counting.atFrom, 0u)
        << "operator new calls in " << (toSample - fromSample) << " " << unit << " of steady state";
}

TEST(FrameLoopAllocations, NonePerFieldInSteadyStateOnTheAirbornePass) {
    if (!bench::allocationCounting()) {
        GTEST_SKIP() << "operator new is not replaced in this build (AddressSanitizer)";
    }
    const DataDirs dirs{std::filesystem::path(NVS_SOURCE_DIR) / "config",
                        std::filesystem::path(NVS_BINARY_DIR) / "cache"};
    Scenario sc = loadScenario(
        std::filesystem::path(NVS_SOURCE_DIR) / "scenarios" / "airborne-pass" / "scenario.toml",
        dirs.config);
    ASSERT_EQ(sc.scan, ScanKind::Interlaced);
    ASSERT_TRUE(sc.rendered && sc.camera.enabled);
    auto render = SceneRenderStage::create(sc, dirs);
    sc.platform.lampMask = render->initialLampMask();
    std::unique_ptr<PlatformSource> platform =
        makePlatformSource(sc.telemetry, sc, ClockKind::Sim, dirs);
    GammaTableCache gammaTables;
    IiccdCameraStage camera(sc.camera.params, "pe", sc.camera.seed,
                            IiccdCameraStage::Controls::Platform, dirs.config, gammaTables);
    // 40 fields from field 20; 34 frames (68 fields): the window closes before the last drain.
    expectNoneInSteadyState(sc, *platform, *render, camera, 34, 20, 60, "fields");
}

// The thermal channel too (issue 30: no allocation per frame): the airborne pass seen by the
// 640 × 512 microbolometer at 30 Hz under the sim clock, the camera moving along its CAN log (the
// G-buffer changes every frame, so every pixel goes from its hit to the radiance), the bolometer
// camera stage with its shutter, 8-bit y4m and metadata outputs; 30 frames of steady state after
// frame 10. (A scene whose objects move is another matter: Embree's rebuild of their BVH calls
// operator new, 3 times a frame on vehicle-drive-lwir's truck; docs/performance.md.)
TEST(FrameLoopAllocations, NonePerFrameInSteadyStateOnTheThermalAirbornePass) {
    if (!bench::allocationCounting()) {
        GTEST_SKIP() << "operator new is not replaced in this build (AddressSanitizer)";
    }
    const std::filesystem::path source = NVS_SOURCE_DIR;
    const DataDirs dirs{source / "config", std::filesystem::path(NVS_BINARY_DIR) / "cache"};
    Scenario sc =
        loadScenario(source / "scenarios" / "airborne-pass" / "scenario.toml", dirs.config);
    sc.camera.thermal = true;
    sc.camera.thermalParams = bolometer::loadThermalCamera(dirs.config, "boson-640");
    sc.camera.thermalParams->frame_rate_Hz = 30.0;
    sc.width = 640;
    sc.height = 512;
    sc.bits = 8;
    sc.scan = ScanKind::Progressive;
    sc.rate = FrameRate::fromHz(30.0);
    ThermalSpec ts;
    ts.weatherFile = dirs.config / "thermal" / "weather" / "rochester-1998-09-02.csv";
    ts.materialsFile = dirs.config / "thermal" / "materials.toml";
    sc.scene.thermal = ts;
    auto render = SceneRenderStage::create(sc, dirs);
    std::unique_ptr<PlatformSource> platform =
        makePlatformSource(sc.telemetry, sc, ClockKind::Sim, dirs);
    BolometerCameraStage camera(*sc.camera.thermalParams, sc.bits, sc.camera.seed,
                                render->thermal()->groundRadianceAt(sc.utcStart_unix_s),
                                dirs.config);
    expectNoneInSteadyState(sc, *platform, *render, camera, 50, 10, 40, "frames");
}

}  // namespace
}  // namespace nvs::rt
