// LWIR table speed: per-pixel lookups (path, sky, aperture radiance, brightness temperature) in
// ns; building a table; loading a cached one.
#include <benchmark/benchmark.h>

#include <filesystem>

#include "sim/lwir/lwir_table.h"
#include "tests/sim/core/test_paths.h"

namespace {

using namespace nvs;

lwir::LwirTableInputs inputs() {
    lwir::LwirTableInputs in;
    in.air.vapourPressure_Pa = 1200.0;
    in.sky.vapourPressure_Pa = 1200.0;
    return in;
}

std::filesystem::path benchCache() {
    return std::filesystem::temp_directory_path() / "nvs_lwir_bench";
}

const lwir::LwirTable& table() {
    static const lwir::LwirTable t = lwir::LwirTable::build(inputs(), test::configDir());
    return t;
}

void BM_ApertureRadiance(benchmark::State& state) {
    double r = 3.0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(table().apertureRadiance_W_m2_sr(0.95, 290.0, 20.0, r));
        r = r > 15000.0 ? 3.0 : r * 1.01;
    }
}
BENCHMARK(BM_ApertureRadiance);

const lwir::LwirTable& slantTable() {
    static const lwir::LwirTable t = [] {
        lwir::LwirTableInputs in = inputs();
        in.slantPaths = true;
        return lwir::LwirTable::build(in, test::configDir());
    }();
    return t;
}

void BM_SlantPath(benchmark::State& state) {
    const lwir::LwirTable& t = slantTable();  // built before the timing starts
    double r = 3.0, z = 1.6;
    for (auto _ : state) {
        benchmark::DoNotOptimize(t.slantPath(250.0, z, r));
        r = r > 15000.0 ? 3.0 : r * 1.01;
        z = z > 3.0 ? 1.6 : z + 1e-3;
    }
}
BENCHMARK(BM_SlantPath);

void BM_BuildSlantTable(benchmark::State& state) {
    lwir::LwirTableInputs in = inputs();
    in.slantPaths = true;
    for (auto _ : state)
        benchmark::DoNotOptimize(lwir::LwirTable::build(in, test::configDir()));
}
BENCHMARK(BM_BuildSlantTable)->Unit(benchmark::kMillisecond)->Iterations(1);

void BM_SkyRadiance(benchmark::State& state) {
    double z = 0.0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(table().skyRadiance_W_m2_sr(z));
        z = z > 1.5 ? 0.0 : z + 1e-3;
    }
}
BENCHMARK(BM_SkyRadiance);

void BM_BrightnessTemperature(benchmark::State& state) {
    double l = 20.0;
    for (auto _ : state) {
        benchmark::DoNotOptimize(table().brightnessTemperature_K(l));
        l = l > 40.0 ? 20.0 : l + 1e-3;
    }
}
BENCHMARK(BM_BrightnessTemperature);

void BM_BuildTable(benchmark::State& state) {
    for (auto _ : state) {
        benchmark::DoNotOptimize(lwir::LwirTable::build(inputs(), test::configDir()));
    }
}
BENCHMARK(BM_BuildTable)->Unit(benchmark::kMillisecond)->Iterations(3);

void BM_LoadCachedTable(benchmark::State& state) {
    const DataDirs dirs{test::configDir(), benchCache()};
    lwir::LwirTable::loadOrBuild(inputs(), dirs);
    for (auto _ : state) {
        bool rebuilt = true;
        benchmark::DoNotOptimize(lwir::LwirTable::loadOrBuild(inputs(), dirs, &rebuilt));
        if (rebuilt) state.SkipWithError("cache was not used");
    }
}
BENCHMARK(BM_LoadCachedTable)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
