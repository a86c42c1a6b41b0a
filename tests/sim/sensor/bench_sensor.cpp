// Speed of the whole IICCD chain, 768 x 494, one core, every stage on (docs/design.md §4.5 budget:
// ≤ 6 ms per field). Input: a checkerboard of 0.003 / 0.009 pe per pixel per field (plus
// 0.02 pe of EBI) with a 20 x 20 px lamp that saturates and blooms (BM_ChainField, AGC off /
// on / BSP); and the same scene 40x brighter, ~0.3 pe per pixel per field, the level of the
// thesis's truth panels at 6 V (BM_ChainFieldBright).

#include <benchmark/benchmark.h>

#include <filesystem>

#include "sim/sensor/chain.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace {

nvs::sensor::CameraParams camera(const char* agc) {
    return nvs::sensor::loadCamera(
        nvs::test::configDir(),
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
    nvs::sensor::IiccdChain chain(cam, 1, nvs::test::configDir(), nvs::test::gammaTables(), {true});
    nvs::ImageF in(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x)
            in(x, y) = (x / 64 + y / 64) % 2 ? 6e10f : 2e10f;
    for (int y = 200; y < 220; ++y)
        for (int x = 300; x < 320; ++x)
            in(x, y) = 1e15f;
    double pe = 0.0;
    for (auto _ : state) {
        const auto& info = chain.process(in.cview());
        pe = info.mean_pe;
        benchmark::DoNotOptimize(info.level_dc);
    }
    state.SetLabel(modes[state.range(0)]);
    state.counters["pe_per_px"] = pe;
}
BENCHMARK(BM_ChainField)->Arg(0)->Arg(1)->Arg(2)->Unit(benchmark::kMillisecond);

void BM_ChainFieldBright(benchmark::State& state) {
    const nvs::sensor::CameraParams cam = camera("off");
    nvs::sensor::IiccdChain chain(cam, 1, nvs::test::configDir(), nvs::test::gammaTables(), {true});
    nvs::ImageF in(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x)
            in(x, y) = (x / 64 + y / 64) % 2 ? 2.4e12f : 0.8e12f;
    for (int y = 200; y < 220; ++y)
        for (int x = 300; x < 320; ++x)
            in(x, y) = 1e15f;
    double pe = 0.0;
    for (auto _ : state) {
        const auto& info = chain.process(in.cview());
        pe = info.mean_pe;
        benchmark::DoNotOptimize(info.level_dc);
    }
    state.counters["pe_per_px"] = pe;
}
BENCHMARK(BM_ChainFieldBright)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
