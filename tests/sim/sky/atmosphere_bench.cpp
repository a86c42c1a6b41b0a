// Atmosphere table speed (issue "Atmosphere table"): per-frame lookup of every term for one
// source geometry ≤ 20 µs; building a table ≤ 30 s; loading a cached one ≤ 100 ms.

#include <benchmark/benchmark.h>

#include <filesystem>

#include "sim/core/units.h"
#include "sim/sky/sky_model.h"
#include "tests/sim/core/test_paths.h"

namespace {

using namespace nvs;

std::filesystem::path benchCache() {
    return std::filesystem::temp_directory_path() / "nvs_atmosphere_bench";
}

nvs::DataDirs dirs() {
    return nvs::DataDirs{nvs::test::configDir(), benchCache()};
}

sky::SkyModelConfig config() {
    sky::SkyModelConfig c;
    c.atmosphere.visibility_km = 23.0;
    return c;
}

// Every term for one Moon geometry: band TOA, direct, diffuse horizontal, night sky, the sky
// radiance and the path terms in one view direction.
void BM_PerFrameLookup(benchmark::State& state) {
    const sky::SkyModel m = sky::SkyModel::create(config(), dirs());
    astro::MoonState moon;
    moon.alt_rad = 0.6;
    moon.phaseAngle_rad = 0.3;
    moon.distanceTopocentric_m = 3.8e8;
    moon.sunDistance_m = 1.5e11;
    double z = 0.2;
    for (auto _ : state) {
        moon.alt_rad = 0.6 + 1e-7 * z;
        const sky::HorizontalTerms h = m.horizontal(sky::SkyModel::kLuxBand, moon);
        const double sky = m.table().skyRadiance(0, z, 1.1, kPi / 2 - moon.alt_rad);
        const double night = m.table().nightSkyRadiance(0, z);
        const sky::PathTerms p = m.table().path(0, 300.0, 2.3, 800.0, 0.2, kPi / 2 - moon.alt_rad);
        benchmark::DoNotOptimize(h);
        benchmark::DoNotOptimize(sky + night);
        benchmark::DoNotOptimize(p);
        z += 1e-3;
        if (z > 1.5) z = 0.0;
    }
}
BENCHMARK(BM_PerFrameLookup)->Unit(benchmark::kMicrosecond);

void BM_BuildTable(benchmark::State& state) {
    for (auto _ : state) {
        std::filesystem::remove_all(benchCache());
        bool rebuilt = false;
        const sky::SkyModel m = sky::SkyModel::create(config(), dirs(), &rebuilt);
        benchmark::DoNotOptimize(m.table().bandCount());
        if (!rebuilt) state.SkipWithError("table was not rebuilt");
    }
}
BENCHMARK(BM_BuildTable)->Unit(benchmark::kMillisecond)->Iterations(2);

void BM_LoadCachedTable(benchmark::State& state) {
    sky::SkyModel::create(config(), dirs());  // make sure the cache exists
    for (auto _ : state) {
        bool rebuilt = true;
        const sky::SkyModel m = sky::SkyModel::create(config(), dirs(), &rebuilt);
        if (rebuilt) state.SkipWithError("cache was not used");
        benchmark::DoNotOptimize(m.table().bandCount());
    }
}
BENCHMARK(BM_LoadCachedTable)->Unit(benchmark::kMillisecond);

}  // namespace

BENCHMARK_MAIN();
