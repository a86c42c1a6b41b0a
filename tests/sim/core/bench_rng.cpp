// Speed of the per-pixel samplers on one 768-pixel row (the PULNiX camera's width), one core:
// poissonRow at uniform means from a dim night scene's to a lamp-lit one's, and the MCP's
// tabulated Gamma draws (gammaTableDraws). Each includes making the row's noise words.

#include <benchmark/benchmark.h>

#include <vector>

#include "sim/core/gamma_table.h"
#include "sim/core/rng.h"

namespace {

constexpr int kWidth = 768;

void BM_PoissonRow(benchmark::State& state) {
    const float mean = static_cast<float>(state.range(0)) / 100.0f;
    std::vector<float> m(kWidth, mean), out(kWidth);
    std::vector<std::uint32_t> words(kWidth);
    const nvs::PixelRng rng(1, nvs::RngStream::Photocathode, 0);
    std::uint32_t y = 0;
    for (auto _ : state) {
        rng.rowWords(y, 0, 0, kWidth / 4, words.data());
        nvs::poissonRow(m.data(), words.data(), out.data(), kWidth, rng, 0, y);
        benchmark::DoNotOptimize(out.data());
        y = (y + 1) % 494;
    }
    state.SetItemsProcessed(state.iterations() * kWidth);
}
// Means ×100: 0.01, 0.3, 1, 3, 8, 20, 60 photoelectrons.
BENCHMARK(BM_PoissonRow)->Arg(1)->Arg(30)->Arg(100)->Arg(300)->Arg(800)->Arg(2000)->Arg(6000);

void BM_GammaTable(benchmark::State& state) {
    nvs::GammaTableCache tables;
    const auto table = tables.forShapeStep(1.0 / 0.6);
    std::vector<float> n(kWidth), out(kWidth);
    for (int x = 0; x < kWidth; ++x)
        n[static_cast<std::size_t>(x)] = static_cast<float>(1 + x % state.range(0));
    std::vector<std::uint32_t> words(kWidth);
    const nvs::PixelRng rng(1, nvs::RngStream::McpGain, 0);
    std::uint32_t y = 0;
    for (auto _ : state) {
        rng.rowWords(y, 0, 0, kWidth / 4, words.data());
        nvs::gammaTableDraws(*table, n.data(), words.data(), out.data(), kWidth, 1000.0f);
        benchmark::DoNotOptimize(out.data());
        y = (y + 1) % 494;
    }
    state.SetItemsProcessed(state.iterations() * kWidth);
}
// N cycling over 1 … range.
BENCHMARK(BM_GammaTable)->Arg(1)->Arg(4)->Arg(32);

}  // namespace

BENCHMARK_MAIN();
