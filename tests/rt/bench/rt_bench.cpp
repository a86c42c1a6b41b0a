// The runtime's own cost per frame, render and sensor excluded (issue: ≤ 0.3 ms): the frame
// loop with stages that do nothing, so what is timed is the two threads' hand-over of slots
// (rings, atomic waits), the platform source's sample at mid-exposure, statistics and the
// dispatch to a sink. Reported as `us_per_frame` (start → join wall time / frames,
// sim clock: the loop runs as fast as it can) and the loop's own `overhead` histogram p99.
#include <benchmark/benchmark.h>

#include <chrono>
#include <vector>

#include "rt/loop/frame_loop.h"
#include "rt/synth/synth.h"

namespace nvs::rt {
namespace {

class NullRender final : public RenderStage {
  public:
    Outputs outputs() const noexcept override { return {false, true}; }
    void render(const FrameRequest&, RadianceTarget, FrameMeta&) noexcept override {}
};
class NullCamera final : public CameraStage {
  public:
    int bits() const noexcept override { return 8; }
    void expose(const FrameRequest&, RadianceFrame, ImageView<std::uint16_t>,
                FieldMeta&) noexcept override {}
};
class NullSink final : public FrameSink {
  public:
    const char* name() const noexcept override { return "null"; }
    int write(const OutputFrame& f) noexcept override {
        benchmark::DoNotOptimize(f.meta->frame);
        return 0;
    }
    int close() noexcept override { return 0; }
    std::string status() const override { return "null"; }
};

void BM_LoopOverheadPerFrame(benchmark::State& state) {
    const std::int64_t frames = 2000;
    double overheadP99_s = 0.0;
    double loopSeconds = 0.0;  // start → join only (slot allocation is setup)
    for (auto _ : state) {
        LoopConfig cfg;
        cfg.rate = FrameRate{60, 1};
        cfg.clock = ClockKind::Sim;
        cfg.frames = frames;
        cfg.width = static_cast<int>(state.range(0));
        cfg.height = static_cast<int>(state.range(1));
        HeldPlatform platform(PlatformState{});
        NullRender render;
        NullCamera camera;
        NullSink sink;
        FrameLoop loop(cfg, platform, render, camera, {&sink});
        std::vector<std::string> msgs;
        const auto t0 = std::chrono::steady_clock::now();
        loop.start(msgs);
        loop.join();
        loopSeconds += std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        overheadP99_s = loop.stats().overhead.quantile_s(0.99);
    }
    state.SetItemsProcessed(state.iterations() * frames);
    state.counters["us_per_frame"] =
        loopSeconds * 1e6 / static_cast<double>(state.iterations() * frames);
    state.counters["overhead_p99_us"] = overheadP99_s * 1e6;
}
BENCHMARK(BM_LoopOverheadPerFrame)
    ->Args({320, 240})
    ->Args({768, 494})
    ->Unit(benchmark::kMillisecond)
    ->UseRealTime();

}  // namespace
}  // namespace nvs::rt

BENCHMARK_MAIN();
