// Speed of the whole IICCD chain, 768 x 494, one core, every stage on (DESIGN §4.5 budget:
// ≤ 6 ms per field). Input: a night scene of ~0.3 pe per pixel per field with a lamp.

#include <benchmark/benchmark.h>

#include <filesystem>

#include "sim/sensor/chain.h"

namespace {

nvs::sensor::CameraParams camera(const char* agc) {
    return nvs::sensor::loadCamera(
        (std::filesystem::path(NVS_SOURCE_DIR) / "config/cameras/pulnix-ag5745ef3.toml").string(),
        {{"agc", agc},
         {"ccd.prnu_rel", "0.05"},
         {"ccd.smear_rel", "0.01"},
         {"ccd.dark_e_s", "100"},
         {"video.gamma", "0.8"}});
}

void BM_ChainField(benchmark::State& state) {
    const char* modes[] = {"off", "agc", "bsp"};
    const nvs::sensor::CameraParams cam = camera(modes[state.range(0)]);
    nvs::sensor::IiccdChain chain(cam, 1, {true});
    nvs::ImageF in(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x)
            in(x, y) = (x / 64 + y / 64) % 2 ? 6e10f : 2e10f;
    for (int y = 200; y < 220; ++y)
        for (int x = 300; x < 320; ++x)
            in(x, y) = 1e15f;
    for (auto _ : state) {
        const auto& info = chain.process(in.cview());
        benchmark::DoNotOptimize(info.level_dc);
    }
    state.SetLabel(modes[state.range(0)]);
}
BENCHMARK(BM_ChainField)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
