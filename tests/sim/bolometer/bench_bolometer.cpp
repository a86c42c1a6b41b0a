// Speed of the whole microbolometer chain, 640 × 512 (boson-640), one core, every stage on:
// a 300 K background with a 310 K block and a horizontal 280–320 K ramp, plateau and linear AGC.
// The budget: the thermal channel, rendering included, ≤ half a core at 30 Hz
// (≤ 16.7 ms per frame); docs/bolometer.md gives this chain's share. The chain plans its FFTs from
// the shipped wisdom (config/fftw/), as nvstim does.

#include <benchmark/benchmark.h>

#include "tests/sim/bolometer/bolometer_test_util.h"

namespace {

// Arg: 0 plateau AGC, 1 linear AGC; 2 plateau without the MTF, 3 plateau without 1/f noise
// (the differences are those stages' shares).
void BM_BolometerFrame(benchmark::State& state) {
    const char* labels[] = {"plateau", "linear", "plateau, no MTF", "plateau, no 1/f"};
    nvs::bolometer::Overrides ov{{"agc.mode", state.range(0) == 1 ? "linear" : "plateau"}};
    if (state.range(0) == 2) ov.emplace("optics.mtf", "false");
    if (state.range(0) == 3) ov.emplace("noise.flicker_rel", "0");
    const nvs::bolometer::ThermalCameraParams cam = nvs::test::thermalPreset("boson-640", ov);
    nvs::bolometer::BolometerChain chain(cam, 1, nvs::test::configDir());
    nvs::ImageF in(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
            const double T =
                (x > 200 && x < 300 && y > 100 && y < 200) ? 310.0 : 280.0 + 40.0 * x / cam.width;
            in(x, y) = static_cast<float>(
                nvs::planckBandRadiance_W_m2_sr(cam.band_lo_um, cam.band_hi_um, T));
        }
    for (int k = 0; k < 30; ++k)
        chain.process(in.cview());  // past the start-up FFC
    for (auto _ : state) {
        const auto& info = chain.process(in.cview());
        benchmark::DoNotOptimize(info.mean_raw);
    }
    state.SetLabel(labels[state.range(0)]);
}
BENCHMARK(BM_BolometerFrame)->DenseRange(0, 3)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
