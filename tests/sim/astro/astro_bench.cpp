// One frame's ephemeris and source evaluation (target ≤ 50 µs, issue "Ephemeris and natural
// light sources"): Sun and Moon positions, lunar irradiance (scalar and spectrum), night sky.

#include <benchmark/benchmark.h>

#include "sim/astro/ephemeris.h"
#include "sim/sky/moon.h"
#include "sim/sky/night_sky.h"
#include "tests/sim/core/test_paths.h"

namespace {

using namespace nvs;

void BM_EphemerisAndSourcesPerFrame(benchmark::State& state) {
    astro::Site site;
    site.lat_deg = 43.16856;
    site.lon_deg = -77.61583;
    site.height_m = 218.0;
    const astro::Ephemeris eph(site);
    const astro::AstroTime t0 = astro::astroTimeFromUtc(astro::parseIsoUtc("1998-09-06T03:00Z"));
    const sky::MoonSource moon = sky::MoonSource::load(test::configDir());
    const sky::NightSkyModel night = sky::NightSkyModel::load(test::configDir());
    Spectrum moonSpectrum, skySpectrum;
    const sky::NightSkyScales scales;
    long long frame = 0;
    for (auto _ : state) {
        const astro::AstroTime t = t0.plusSeconds(static_cast<double>(frame++) / 59.94);
        const astro::SunMoonState s = eph.compute(t);
        const double e = moon.illuminanceToa_lux(s.moon);
        moon.spectralIrradianceToa(s.moon, moonSpectrum);
        night.radiance(scales, skySpectrum);
        benchmark::DoNotOptimize(e);
        benchmark::DoNotOptimize(moonSpectrum);
        benchmark::DoNotOptimize(skySpectrum);
    }
}
BENCHMARK(BM_EphemerisAndSourcesPerFrame)->Unit(benchmark::kMicrosecond);

void BM_EphemerisOnly(benchmark::State& state) {
    astro::Site site;
    const astro::Ephemeris eph(site);
    const astro::AstroTime t0 = astro::astroTimeFromUtc(astro::parseIsoUtc("2024-01-25T17:54Z"));
    long long frame = 0;
    for (auto _ : state) {
        const astro::SunMoonState s = eph.compute(t0.plusSeconds(static_cast<double>(frame++)));
        benchmark::DoNotOptimize(s);
    }
}
BENCHMARK(BM_EphemerisOnly)->Unit(benchmark::kMicrosecond);

}  // namespace

BENCHMARK_MAIN();
