// Per-step and per-frame code allocates nothing (docs/style.md §3): SurfaceSolver::step and
// SurfaceTemperatureTable::at, counted by replacing the global operator new in this binary
// (its own executable, so the other thermal tests keep the usual one).
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "sim/thermal/heat_balance.h"

namespace {
std::atomic<std::uint64_t> gNews{0};
}  // namespace

// AddressSanitizer keeps its own operator new (as rt/bench/count_new.cpp does, this one steps
// aside there).
#if !defined(__SANITIZE_ADDRESS__)
#define NVS_THERMAL_COUNT_NEW 1
void* operator new(std::size_t n) {
    gNews.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(n ? n : 1)) return p;
    throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
#endif

namespace nvs::thermal {
namespace {

const std::string kConfig = std::string(NVS_SOURCE_DIR) + "/config/thermal/";

TEST(ThermalAllocation, NoneInStepsOrTableLookups) {
#ifndef NVS_THERMAL_COUNT_NEW
    GTEST_SKIP() << "operator new is not replaced in this build (AddressSanitizer)";
#endif
    const MaterialLibrary lib = MaterialLibrary::load(kConfig + "materials.toml");
    const WeatherSeries w = WeatherSeries::load(kConfig + "weather/rochester-1998-09-02.csv");
    astro::Site site;
    site.lat_deg = 43.16856;
    site.lon_deg = -77.61583;
    const astro::Ephemeris eph(site);
    const astro::AstroTime t0 = astro::astroTimeFromUtc(astro::parseIsoUtc("1998-08-31T00:00Z"));
    SurfaceSolver s(lib.get("grass", {}), Exposure{}, GridParams{}, 290.0);
    SurfaceClass c;
    c.material = lib.get("painted_metal", {});
    const double t = utcSeconds("1998-09-02T04:00Z", "test");
    const std::uint64_t setup = gNews.load();
    const SurfaceTemperatureTable table =
        solveHeatBalance({c}, w, site, HeatBalanceParams{}, t - 600.0, t);
    EXPECT_GT(gNews.load(), setup);  // the counter counts: set-up allocates
    const ForcingSample f0 = forcingAt(eph, t0, w.start_s(), w, ForcingParams{}, w.start_s());
    s.step(f0, 1.0, 60.0);  // warm-up
    const std::uint64_t before = gNews.load();
    double sum = 0.0;
    for (int i = 1; i < 600; ++i) {
        const ForcingSample f =
            forcingAt(eph, t0, w.start_s(), w, ForcingParams{}, w.start_s() + 60.0 * i);
        s.step(f, 1.0, 60.0);
        sum += table.at(0, t - 600.0 + i);
    }
    EXPECT_EQ(gNews.load() - before, 0u);
    EXPECT_GT(sum, 0.0);
}

}  // namespace
}  // namespace nvs::thermal
