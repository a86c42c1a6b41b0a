// The LWIR table: a blackbody panel through the tabulated path against a direct spectral
// integration, the lookups' limits, and the cache.
#include "sim/lwir/lwir_table.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <fstream>

#include "sim/core/csv.h"
#include "sim/core/error.h"
#include "sim/core/planck.h"
#include "tests/sim/lwir/lwir_test_common.h"

namespace nvs::lwir {
namespace {

LwirTableInputs inputs() {
    LwirTableInputs in;
    in.air.temperature_K = 288.15;
    in.air.vapourPressure_Pa = 1400.0;
    in.sky.airTemperature_K = 288.15;
    in.sky.vapourPressure_Pa = 1400.0;
    in.band = BandResponse::flat(7.5, 13.5);
    return in;
}

const LwirTable& table() {
    static const LwirTable t = LwirTable::build(inputs(), nvs::test::configDir());
    return t;
}

// ∫_{7.5}^{13.5} [τ(λ) B(λ, T) + (1 − τ(λ)) B(λ, T_air)] dλ by Simpson's rule every 1 nm, with
// τ(λ) from the spectral model interpolated linearly in wavenumber: independent of the table's
// grid weights, band averaging and range interpolation.
double direct(double panel_K, double range_m, double (*response)(double um) = nullptr) {
    const LwirTableInputs in = inputs();
    const Spectral tau = homogeneousTransmittance(test::data(), in.air, range_m);
    const auto tauAt = [&](double um) {
        const double u = (1e4 / um - Grid::kFirst_cm1) / Grid::kStep_cm1;
        const int i = static_cast<int>(u);
        const double f = u - i;
        return tau[i] * (1.0 - f) + tau[i + 1] * f;
    };
    const auto f = [&](double um) {
        const double t = tauAt(um);
        const double r = response != nullptr ? response(um) : 1.0;
        return r *
               (t * planckSpectralRadiance_W_m2_sr_m(um * 1e-6, panel_K) +
                (1.0 - t) * planckSpectralRadiance_W_m2_sr_m(um * 1e-6, in.air.temperature_K)) *
               1e-6;
    };
    const int n = 6000;
    const double h = 6.0 / n;
    double s = f(7.5) + f(13.5);
    for (int k = 1; k < n; ++k)
        s += (k % 2 ? 4.0 : 2.0) * f(7.5 + k * h);
    return s * h / 3.0;
}

TEST(LwirTable, BlackbodyPanelWithinOnePercentOfDirectIntegration) {
    for (double panel : {263.15, 300.0, 330.0}) {
        for (double r : {10.0, 1000.0}) {
            const double viaTable = table().apertureRadiance_W_m2_sr(1.0, panel, 0.0, r);
            const double ref = direct(panel, r);
            std::printf("flat 7.5-13.5 um, %.2f K at %5.0f m: table/direct − 1 = %+.2e\n", panel, r,
                        viaTable / ref - 1.0);
            EXPECT_NEAR(viaTable / ref, 1.0, 0.01) << panel << " K at " << r << " m";
        }
    }
}

// A triangular response, 0 at 7.5 and 13.5 µm and 1 at 10.5 µm (a microbolometer's shape
// more than a flat band's).
double triangle(double um) {
    return std::max(0.0, 1.0 - std::fabs(um - 10.5) / 3.0);
}

TEST(LwirTable, ShapedResponsePanelWithinOnePercentOfDirectIntegration) {
    const auto csv = std::filesystem::temp_directory_path() / "nvs_lwir_triangle.csv";
    std::ofstream(csv) << "# a triangular response written by the test\nwavelength_um,response\n"
                          "7.5,0\n10.5,1\n13.5,0\n";
    LwirTableInputs in = inputs();
    in.band = BandResponse::fromCsv(csv);
    const LwirTable t = LwirTable::build(in, nvs::test::configDir());
    for (double panel : {263.15, 330.0}) {
        for (double r : {10.0, 1000.0}) {
            const double ratio =
                t.apertureRadiance_W_m2_sr(1.0, panel, 0.0, r) / direct(panel, r, triangle);
            std::printf("triangle, %.2f K at %5.0f m: table/direct − 1 = %+.2e\n", panel, r,
                        ratio - 1.0);
            EXPECT_NEAR(ratio, 1.0, 0.01) << panel << " K at " << r << " m";
        }
    }
}

TEST(LwirTable, InterpolationBetweenRangeNodes) {
    // 60 ranges between the nodes (1.3 m … 19 km, not on the 10.6 % grid): τ within 5e-4 and
    // L_path within 0.3 % of the direct computation, and the isothermal identity exact.
    const LwirTableInputs in = inputs();
    const double bAir = table().blackbody_W_m2_sr(in.air.temperature_K);
    double worstTau = 0.0, worstL = 0.0;
    for (int k = 0; k < 60; ++k) {
        const double r = 1.3 * std::pow(19000.0 / 1.3, k / 59.0);
        const PathBand d = horizontalPath(test::data(), in.band, in.air, r);
        const PathBand t = table().path(r);
        worstTau = std::max(worstTau, std::fabs(t.transmittance - d.transmittance));
        worstL = std::max(worstL, std::fabs(t.pathRadiance_W_m2_sr / d.pathRadiance_W_m2_sr - 1.0));
        EXPECT_NEAR((t.transmittance * bAir + t.pathRadiance_W_m2_sr) / bAir, 1.0, 2e-3) << r;
    }
    std::printf("worst |Δτ| %.1e, worst L_path error %.1e\n", worstTau, worstL);
    EXPECT_LT(worstTau, 5e-4);
    EXPECT_LT(worstL, 3e-3);
}

TEST(LwirTable, RangeLimits) {
    // τ → 1 and L_path → 0 as r → 0; τ falls and L_path rises with range; L_path → B_band(T_air)
    // as τ → 0 (checked on the direct path, band_test.cpp).
    EXPECT_DOUBLE_EQ(table().path(0.0).transmittance, 1.0);
    EXPECT_GT(table().path(1e-3).transmittance, 0.99999);
    EXPECT_LT(table().path(1e-3).pathRadiance_W_m2_sr, 1e-4);
    double prevT = 1.0, prevL = 0.0;
    for (double r = 0.5; r < 20000.0; r *= 1.7) {
        const PathBand p = table().path(r);
        EXPECT_LT(p.transmittance, prevT);
        EXPECT_GT(p.pathRadiance_W_m2_sr, prevL);
        prevT = p.transmittance;
        prevL = p.pathRadiance_W_m2_sr;
    }
}

TEST(LwirTable, LookupsMatchTheDirectComputation) {
    const LwirTableInputs in = inputs();
    for (double r : {3.3, 77.0, 4321.0}) {
        const PathBand d = horizontalPath(test::data(), in.band, in.air, r);
        const PathBand t = table().path(r);
        EXPECT_NEAR(t.transmittance / d.transmittance, 1.0, 2e-3) << r;
        EXPECT_NEAR(t.pathRadiance_W_m2_sr / d.pathRadiance_W_m2_sr, 1.0, 5e-3) << r;
    }
    for (double t : {250.0, 288.15, 310.3}) {
        EXPECT_NEAR(table().blackbody_W_m2_sr(t) / planckBandRadiance_W_m2_sr(7.5, 13.5, t), 1.0,
                    1e-3);
        EXPECT_NEAR(table().brightnessTemperature_K(table().blackbody_W_m2_sr(t)), t, 1e-6);
    }
    // E_sky/π = 2 ∫ L(θ) cosθ sinθ dθ: a 3-point-per-degree Simpson sum of the direct sky.
    {
        const int n = 90;
        const double h = 0.5 * 3.14159265358979323846 / n;
        double s = 0.0;
        for (int k = 0; k <= n; ++k) {
            const double th = k * h;
            const double w = (k == 0 || k == n) ? 1.0 : (k % 2 ? 4.0 : 2.0);
            s += w * skyBandRadiance_W_m2_sr(test::data(), in.band, in.sky, th) * std::cos(th) *
                 std::sin(th);
        }
        EXPECT_NEAR(table().skyDiffuseRadiance_W_m2_sr() / (2.0 * s * h / 3.0), 1.0, 2e-3);
        // Between the zenith's radiance and the horizon's.
        EXPECT_GT(table().skyDiffuseRadiance_W_m2_sr(), table().skyRadiance_W_m2_sr(0.0));
        EXPECT_LT(table().skyDiffuseRadiance_W_m2_sr(), table().skyRadiance_W_m2_sr(1.5707));
        EXPECT_NEAR(table().tiltedSkyRadiance_W_m2_sr(0.0) / table().skyDiffuseRadiance_W_m2_sr(),
                    1.0, 2e-3);
        EXPECT_NEAR(table().tiltedSkyRadiance_W_m2_sr(3.14159265358979), 0.0, 1e-6);
    }
    const double z = 0.7;
    EXPECT_NEAR(
        table().skyRadiance_W_m2_sr(z) / skyBandRadiance_W_m2_sr(test::data(), in.band, in.sky, z),
        1.0, 2e-3);
}

std::filesystem::path freshDir(const char* name) {
    const auto d = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(d);
    return d;
}

TEST(LwirTable, CacheIsReusedAndRebuiltWhenCorrupt) {
    const DataDirs dirs{nvs::test::configDir(), freshDir("nvs_lwir_cache")};
    bool rebuilt = false;
    const LwirTable a = LwirTable::loadOrBuild(inputs(), dirs, &rebuilt);
    EXPECT_TRUE(rebuilt);
    const LwirTable b = LwirTable::loadOrBuild(inputs(), dirs, &rebuilt);
    EXPECT_FALSE(rebuilt);
    EXPECT_EQ(a.path(123.0).transmittance, b.path(123.0).transmittance);
    EXPECT_EQ(a.skyRadiance_W_m2_sr(0.4), b.skyRadiance_W_m2_sr(0.4));
    // Another night is another key.
    LwirTableInputs wet = inputs();
    wet.air.vapourPressure_Pa = 2000.0;
    EXPECT_NE(LwirTable::cacheKey(wet, dirs.config), LwirTable::cacheKey(inputs(), dirs.config));
    // Flip a byte in the payload: detected and rebuilt.
    const auto file = dirs.cache / ("lwir-" + LwirTable::cacheKey(inputs(), dirs.config) + ".bin");
    {
        std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(100);
        f.put('\x5a');
    }
    LwirTable::loadOrBuild(inputs(), dirs, &rebuilt);
    EXPECT_TRUE(rebuilt);
}

TEST(LwirTable, LookupsSurviveNonFiniteInput) {
    const double nan = std::nan("");
    EXPECT_DOUBLE_EQ(table().path(nan).transmittance, 1.0);
    EXPECT_DOUBLE_EQ(table().skyRadiance_W_m2_sr(nan), table().skyRadiance_W_m2_sr(0.0));
    EXPECT_DOUBLE_EQ(table().blackbody_W_m2_sr(nan), table().blackbody_W_m2_sr(150.0));
    EXPECT_DOUBLE_EQ(table().brightnessTemperature_K(nan), 150.0);
    EXPECT_GT(table().path(1e9).transmittance, 0.0);  // beyond 20 km: the 20 km value
    EXPECT_DOUBLE_EQ(table().path(1e9).transmittance, table().path(20000.0).transmittance);
}

TEST(LwirTable, InputsFromWeather) {
    const LwirTableInputs in = LwirTableInputs::fromWeather(288.15, 278.15, 100000.0, 0.25, 800.0,
                                                            BandResponse::flat(8, 14));
    // Magnus at 5 °C: 610.94 exp(17.625·5/248.04) = 872.5 Pa (IAPWS-95: 872.6 Pa).
    EXPECT_NEAR(in.air.vapourPressure_Pa, 872.6, 1.5);
    EXPECT_EQ(in.sky.vapourPressure_Pa, in.air.vapourPressure_Pa);
    EXPECT_EQ(in.sky.pressure_Pa, 100000.0);
    EXPECT_EQ(in.sky.cloudFraction, 0.25);
    EXPECT_THROW(
        LwirTableInputs::fromWeather(280.0, 285.0, 1e5, 0.0, 1000.0, BandResponse::flat(8, 14)),
        SetupError);
    EXPECT_THROW(
        LwirTableInputs::fromWeather(280.0, 275.0, 1e5, 1.5, 1000.0, BandResponse::flat(8, 14)),
        SetupError);
}

TEST(LwirTable, ChangedCoefficientsChangeTheKey) {
    // A cached table is keyed by the coefficient files' values: editing one makes a new key,
    // so a stale table is never used.
    const auto dir = std::filesystem::temp_directory_path() / "nvs_lwir_key_config";
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "lwir");
    for (const auto& e : std::filesystem::directory_iterator(nvs::test::configDir() / "lwir")) {
        std::filesystem::copy_file(e.path(), dir / "lwir" / e.path().filename());
    }
    const std::string before = LwirTable::cacheKey(inputs(), dir);
    EXPECT_EQ(before, LwirTable::cacheKey(inputs(), nvs::test::configDir()));
    const auto f = dir / "lwir" / "h2o_continuum_roberts1976.csv";
    std::ifstream in(f);
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    in.close();
    text.replace(text.find("gamma,0.002"), 11, "gamma,0.003");
    std::ofstream(f) << text;
    EXPECT_NE(LwirTable::cacheKey(inputs(), dir), before);
    // And another band, another key.
    LwirTableInputs other = inputs();
    other.band = BandResponse::flat(8.0, 12.0);
    EXPECT_NE(LwirTable::cacheKey(other, nvs::test::configDir()), before);
}

TEST(LwirTable, UnwritableCacheStillGivesATable) {
    // A cache "folder" that is a file: nothing can be written there; the table is built, used,
    // and the failure is a warning, not an error.
    const auto file = std::filesystem::temp_directory_path() / "nvs_lwir_cache_is_a_file";
    std::filesystem::remove_all(file);
    std::ofstream(file) << "not a folder\n";
    bool rebuilt = false;
    const LwirTable t =
        LwirTable::loadOrBuild(inputs(), DataDirs{nvs::test::configDir(), file}, &rebuilt);
    EXPECT_TRUE(rebuilt);
    EXPECT_EQ(t.path(500.0).transmittance, table().path(500.0).transmittance);
    // No cache folder at all: built each time.
    const LwirTable u =
        LwirTable::loadOrBuild(inputs(), DataDirs{nvs::test::configDir(), {}}, &rebuilt);
    EXPECT_TRUE(rebuilt);
    EXPECT_EQ(u.skyRadiance_W_m2_sr(0.2), table().skyRadiance_W_m2_sr(0.2));
}

TEST(LwirTable, BadInputThrows) {
    LwirTableInputs in = inputs();
    in.air.vapourPressure_Pa = -1.0;
    EXPECT_THROW(LwirTable::build(in, nvs::test::configDir()), SetupError);
    EXPECT_THROW(LwirTable::build(inputs(), "/nonexistent/config"), SetupError);
}

}  // namespace
}  // namespace nvs::lwir

namespace nvs::lwir {
namespace {

LwirTableInputs slantInputs(double lapse_K_m, double waterScale_m) {
    LwirTableInputs in = inputs();
    in.sky.lapseRate_K_m = lapse_K_m;
    in.sky.waterScaleHeight_m = waterScale_m;
    in.slantPaths = true;
    return in;
}

const LwirTable& slantTable() {
    static const LwirTable t =
        LwirTable::build(slantInputs(0.0065, 2000.0), nvs::test::configDir());
    return t;
}

TEST(LwirSlant, HorizontalAtTheGroundIsTheHorizontalPath) {
    ASSERT_TRUE(slantTable().hasSlantPaths());
    ASSERT_FALSE(table().hasSlantPaths());
    for (double r : {5.0, 250.0, 2000.0}) {
        const PathBand s = slantTable().slantPath(0.0, 0.5 * 3.14159265358979, r);
        const PathBand h = table().path(r);
        EXPECT_NEAR(s.transmittance / h.transmittance, 1.0, 5e-3) << r;
        EXPECT_NEAR(s.pathRadiance_W_m2_sr / h.pathRadiance_W_m2_sr, 1.0, 1e-2) << r;
    }
    // Without a slant table, slantPath is the horizontal path.
    EXPECT_EQ(table().slantPath(300.0, 2.5, 700.0).transmittance,
              table().path(700.0).transmittance);
}

TEST(LwirSlant, IsothermalAtmosphereIsABlackbodyAlongAnyLine) {
    // Kirchhoff along a slant line: with no lapse the air is at T_air everywhere, so
    // τ B(T_air) + L_path = B(T_air) whatever the height, direction and range.
    const LwirTableInputs in = slantInputs(0.0, 2000.0);
    const double b = bandRadiance_W_m2_sr(in.band, in.sky.airTemperature_K);
    for (double h : {0.0, 50.0, 1000.0}) {
        for (double z : {0.3, 1.6, 2.4}) {
            const auto p =
                slantPathProfile(test::data(), in.band, in.sky, h, z, {30.0, 900.0, 15000.0});
            for (const PathBand& q : p) {
                EXPECT_NEAR((q.transmittance * b + q.pathRadiance_W_m2_sr) / b, 1.0, 1e-9)
                    << h << " m, " << z << " rad";
            }
        }
    }
    // The table's interpolation between heights and angles keeps the identity.
    const LwirTable t = LwirTable::build(in, nvs::test::configDir());
    for (double h : {7.0, 640.0}) {
        for (double z : {0.31, 1.6, 2.47}) {
            for (double r : {0.4, 31.0, 15000.0}) {
                const PathBand q = t.slantPath(h, z, r);
                EXPECT_NEAR((q.transmittance * b + q.pathRadiance_W_m2_sr) / b, 1.0, 1e-3)
                    << h << " m, " << z << " rad, " << r << " m";
            }
        }
    }
}

TEST(LwirSlant, LookingDownThroughDrierColderAirIsClearerAndDarker) {
    // From 300 m at 45° below the horizon to the ground, 424 m: the air above the ground is
    // drier (2 km scale height) and colder (6.5 K/km) than the ground's, so τ is higher and
    // L_path lower than on a 424 m path at the ground.
    const double down = 3.14159265358979 * 0.75, r = 300.0 / std::cos(3.14159265358979 * 0.25);
    const PathBand s = slantTable().slantPath(300.0, down, r);
    const PathBand h = table().path(r);
    EXPECT_GT(s.transmittance, h.transmittance);
    EXPECT_LT(s.pathRadiance_W_m2_sr, h.pathRadiance_W_m2_sr);
    // Looking up through the same height gain is clearer still than looking along the ground.
    EXPECT_GT(slantTable().slantPath(0.0, 0.25 * 3.14159265358979, r).transmittance,
              h.transmittance);
    // Near the tabulated heights and angles, the lookup matches the direct computation.
    const LwirTableInputs in = slantInputs(0.0065, 2000.0);
    const auto direct = slantPathProfile(test::data(), in.band, in.sky, 100.0,
                                         1.5 * 3.14159265358979 / 3.0 * 2.0 / 2.0, {1234.0});
    const PathBand l =
        slantTable().slantPath(100.0, 1.5 * 3.14159265358979 / 3.0 * 2.0 / 2.0, 1234.0);
    EXPECT_NEAR(l.transmittance / direct[0].transmittance, 1.0, 5e-3);
    EXPECT_NEAR(l.pathRadiance_W_m2_sr / direct[0].pathRadiance_W_m2_sr, 1.0, 1e-2);
}

TEST(LwirSlant, LinesOfSightToTheGroundAgainstLowtran7) {
    // LOWTRAN 7 slant paths from 0.3, 1 and 3 km down to the ground through its US Standard 1976
    // atmosphere (tests/data/lowtran7/slant_us76_to_ground_700_1340cm.csv): band τ and path
    // radiance over 8–14 µm, the ground's emission taken out (SUMVV − τ B(288.2 K)). The model
    // gets LOWTRAN's surface air, lapse, CO2, ozone and a 2.8 km water scale height. As on
    // horizontal paths it is the clearer (docs/lwir.md §6): τ within 0.04 and never lower by
    // over 0.01, L_path within 25 %.
    const CsvTable lt = CsvTable::load(nvs::test::sourceDir() / "tests/data/lowtran7" /
                                       "slant_us76_to_ground_700_1340cm.csv");
    const std::size_t ch = lt.column("height_km"), cz = lt.column("zenith_deg"),
                      cv = lt.column("wavenumber_cm-1"), ct = lt.column("transmittance"),
                      cr = lt.column("radiance_W_cm-2_sr-1_um-1");
    SkyParams s;
    s.airTemperature_K = 288.2;
    s.pressure_Pa = 101300.0;
    s.vapourPressure_Pa = 7.745e-3 * 101300.0;
    s.waterScaleHeight_m = 2800.0;
    s.co2_ppm = 330.0;
    s.o3Column_DU = 345.0;
    s.o3Surface_ppb = 25.0;
    const BandResponse band = BandResponse::flat(8.0, 14.0);
    const double cases[5][2] = {
        {0.3, 135.0}, {0.3, 180.0}, {1.0, 135.0}, {1.0, 180.0}, {3.0, 180.0}};
    for (const auto& c : cases) {
        double num = 0.0, den = 0.0, lPath = 0.0;
        for (std::size_t i = 0; i < lt.rowCount(); ++i) {
            if (lt.number(i, ch) != c[0] || lt.number(i, cz) != c[1]) continue;
            const double nu = lt.number(i, cv);
            const double lo = std::max(8.0, 1e4 / (nu + 2.5)),
                         hi = std::min(14.0, 1e4 / (nu - 2.5));
            if (!(hi > lo)) continue;
            const double b = planckSpectralRadiance_W_m2_sr_m(1e-2 / nu, 288.2) * 1e-6;
            const double tau = lt.number(i, ct);
            num += tau * b * (hi - lo);
            den += b * (hi - lo);
            lPath += (lt.number(i, cr) * 1e4 - tau * b) * (hi - lo);
        }
        const double z = c[1] * 3.14159265358979 / 180.0;
        const double r = c[0] * 1e3 / std::fabs(std::cos(z));
        const PathBand ours = slantPathProfile(test::data(), band, s, c[0] * 1e3, z, {r})[0];
        std::printf("%.1f km at %.0f°: τ %.4f / LOWTRAN %.4f, L_path %.3f / %.3f\n", c[0], c[1],
                    ours.transmittance, num / den, ours.pathRadiance_W_m2_sr, lPath);
        EXPECT_NEAR(ours.transmittance, num / den, 0.04);
        EXPECT_GT(ours.transmittance, num / den - 0.01);
        EXPECT_NEAR(ours.pathRadiance_W_m2_sr / lPath, 1.0, 0.25);
    }
}

TEST(LwirSlant, CachedSlantTableRoundTrips) {
    const DataDirs dirs{nvs::test::configDir(), freshDir("nvs_lwir_slant_cache")};
    bool rebuilt = false;
    const LwirTable a = LwirTable::loadOrBuild(slantInputs(0.0065, 2000.0), dirs, &rebuilt);
    EXPECT_TRUE(rebuilt);
    const LwirTable b = LwirTable::loadOrBuild(slantInputs(0.0065, 2000.0), dirs, &rebuilt);
    EXPECT_FALSE(rebuilt);
    EXPECT_TRUE(b.hasSlantPaths());
    EXPECT_EQ(a.slantPath(77.0, 2.0, 640.0).transmittance,
              b.slantPath(77.0, 2.0, 640.0).transmittance);
}

}  // namespace
}  // namespace nvs::lwir
