// The cached atmosphere table: agreement with the direct computation, cache behaviour, and
// path radiance limits.
#include "sim/sky/atmosphere_table.h"

#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <fstream>

#include "sim/core/photometry.h"
#include "sim/core/planck.h"
#include "sim/core/units.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::sky {
namespace {

// V(λ) from the source tree's config/ (loaded once for this file's tests).
const Photometry& photometry() {
    static const Photometry p(test::configDir());
    return p;
}

AtmosphereTableInputs inputs(double visibility_km) {
    AtmosphereTableInputs in;
    in.atmosphere.visibility_km = visibility_km;
    in.sourceShape = planckRadiance_W_m2_sr_nm(4100.0);  // moonlight-like reddened sunlight
    in.nightSky.airglowRadiance_W_m2_sr_nm = Spectrum(2e-9);
    in.nightSky.continuumRadiance_W_m2_sr_nm = Spectrum(1e-9);
    in.bands.push_back({"lux", photometry().photopicV() * kLuminousEfficacy_lm_W});
    in.bands.push_back(
        {"nir", Spectrum::fromFunction([](double l) { return l > 750 ? 1.0 : 0.0; })});
    return in;
}

std::filesystem::path freshDir(const char* name) {
    const auto d = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(d);
    return d;
}

class AtmosphereTableTest : public ::testing::Test {
  protected:
    static void SetUpTestSuite() {
        in_ = new AtmosphereTableInputs(inputs(23.0));
        table_ = new AtmosphereTable(AtmosphereTable::build(*in_, test::configDir()));
        atm_ = new Atmosphere(in_->atmosphere, test::configDir());
    }
    static void TearDownTestSuite() {
        delete table_;
        delete atm_;
        delete in_;
    }
    double bandOf(const Spectrum& x, int b) const {
        const Spectrum sw = in_->sourceShape * in_->bands[b].weight;
        return integrateProduct_nm(x, sw) /
               integrateProduct_nm(in_->sourceShape, in_->bands[b].weight);
    }
    static AtmosphereTableInputs* in_;
    static AtmosphereTable* table_;
    static Atmosphere* atm_;
};
AtmosphereTableInputs* AtmosphereTableTest::in_ = nullptr;
AtmosphereTable* AtmosphereTableTest::table_ = nullptr;
Atmosphere* AtmosphereTableTest::atm_ = nullptr;

// Off-grid lookups against the spectral model they interpolate.
TEST_F(AtmosphereTableTest, InterpolationMatchesDirectComputation) {
    for (int b = 0; b < 2; ++b) {
        for (double z_deg : {7.3, 41.1, 75.9, 87.6}) {
            const double z = z_deg * kRadPerDeg;
            EXPECT_NEAR(table_->directTransmittance(b, z) / bandOf(atm_->directTransmittance(z), b),
                        1.0, 0.01)
                << b << " " << z_deg;
            EXPECT_NEAR(table_->diffuseHorizontal(b, z) /
                            bandOf(atm_->diffuseHorizontalPerIrradiance(z), b),
                        1.0, 0.02)
                << b << " " << z_deg;
        }
        for (double zv_deg : {13.0, 51.0, 83.0}) {
            for (double dphi_deg : {22.0, 97.0, 171.0}) {
                const double zv = zv_deg * kRadPerDeg, zs = 47.0 * kRadPerDeg;
                const double dphi = dphi_deg * kRadPerDeg;
                const double cosPsi =
                    std::cos(zv) * std::cos(zs) + std::sin(zv) * std::sin(zs) * std::cos(dphi);
                Spectrum l;
                atm_->skyRadiancePerIrradiance(zv, zs, cosPsi, &l);
                EXPECT_NEAR(table_->skyRadiance(b, zv, dphi, zs) / bandOf(l, b), 1.0, 0.03)
                    << b << " " << zv_deg << " " << dphi_deg;
                // Azimuth is symmetric about the source's vertical plane.
                EXPECT_DOUBLE_EQ(table_->skyRadiance(b, zv, -dphi, zs),
                                 table_->skyRadiance(b, zv, dphi, zs));
            }
        }
    }
    EXPECT_EQ(table_->directTransmittance(0, 97.0 * kRadPerDeg), 0.0);
    EXPECT_EQ(table_->skyRadiance(0, 0.3, 0.0, 100.0 * kRadPerDeg), 0.0);
}

// The hemispheric integral of the tabulated sky radiance is the tabulated diffuse irradiance.
TEST_F(AtmosphereTableTest, SkyRadianceIntegratesToDiffuseIrradiance) {
    const double zs = 50.0 * kRadPerDeg;
    double e = 0.0;
    const int nt = 90, np = 72;
    for (int i = 0; i < nt; ++i) {
        const double zv = (i + 0.5) * (kPi / 2) / nt;
        for (int j = 0; j < np; ++j) {
            const double dphi = (j + 0.5) * kTwoPi / np;
            e += table_->skyRadiance(0, zv, dphi, zs) * std::cos(zv) * std::sin(zv) *
                 (kPi / 2 / nt) * (kTwoPi / np);
        }
    }
    EXPECT_NEAR(e / table_->diffuseHorizontal(0, zs), 1.0, 0.03);
}

// The night sky keeps its horizontal irradiance: π (airglow + continuum), band-weighted.
TEST_F(AtmosphereTableTest, NightSkyKeepsHorizontalIrradiance) {
    const double expected = kPi * integrateProduct_nm(Spectrum(3e-9), in_->bands[0].weight);
    EXPECT_NEAR(table_->nightSkyHorizontal(0) / expected, 1.0, 1e-9);
    double e = 0.0;
    const int n = 900;
    for (int i = 0; i < n; ++i) {
        const double z = (i + 0.5) * (kPi / 2) / n;
        e += table_->nightSkyRadiance(0, z) * std::cos(z) * std::sin(z) * kTwoPi * (kPi / 2 / n);
    }
    EXPECT_NEAR(e / expected, 1.0, 0.02);
    // Airglow brightens from the zenith toward z ≈ 75° (van Rhijn) before extinction wins.
    EXPECT_GT(table_->nightSkyRadiance(0, 75.0 * kRadPerDeg), table_->nightSkyRadiance(0, 0.0));
}

// Path radiance: none over zero range; over a long horizontal path it approaches the
// equilibrium J/β (Koschmieder's horizon sky) and the transmittance goes to zero.
TEST_F(AtmosphereTableTest, PathRadianceLimits) {
    const double zs = 40.0 * kRadPerDeg;
    const PathTerms none = table_->path(0, 10.0, kPi / 2, 0.0, 0.5, zs);
    EXPECT_EQ(none.radiancePerIrradiance, 0.0);
    EXPECT_EQ(none.transmittance, 1.0);
    const PathTerms shortPath = table_->path(0, 10.0, kPi / 2, 100.0, 0.5, zs);
    const PathTerms longPath = table_->path(0, 10.0, kPi / 2, 100e3, 0.5, zs);
    EXPECT_GT(shortPath.transmittance, 0.98);
    EXPECT_LT(longPath.transmittance, 1e-3);
    EXPECT_GT(longPath.radiancePerIrradiance, 50.0 * shortPath.radiancePerIrradiance);
    // 1 − T grows linearly at first: radiance over 100 m ≈ 2 × radiance over 50 m.
    const PathTerms half = table_->path(0, 10.0, kPi / 2, 50.0, 0.5, zs);
    EXPECT_NEAR(shortPath.radiancePerIrradiance / half.radiancePerIrradiance, 2.0, 0.02);
    // Koschmieder: 3.912/V at 550 nm is the ground extinction; a 23 km path transmits ~2 %.
    const PathTerms vis = table_->path(0, 0.0, kPi / 2, 23e3, 0.5, zs);
    EXPECT_NEAR(vis.transmittance, 0.02, 0.01);
}

TEST(AtmosphereTableCache, SecondLoadUsesCacheAndCorruptionRebuilds) {
    const auto dir = freshDir("nvs_atm_cache_test");
    const AtmosphereTableInputs in = inputs(40.0);
    bool rebuilt = false;
    const AtmosphereTable a =
        AtmosphereTable::loadOrBuild(in, DataDirs{test::configDir(), dir}, &rebuilt);
    EXPECT_TRUE(rebuilt);
    const auto t0 = std::chrono::steady_clock::now();
    const AtmosphereTable b =
        AtmosphereTable::loadOrBuild(in, DataDirs{test::configDir(), dir}, &rebuilt);
    const double load_s =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    EXPECT_FALSE(rebuilt);
    EXPECT_LT(load_s, 0.5);  // the benchmark holds the 100 ms bound; this guards gross regressions
    EXPECT_EQ(a.skyRadiance(1, 0.4, 1.0, 0.7), b.skyRadiance(1, 0.4, 1.0, 0.7));

    const auto file = dir / ("atmosphere-" + AtmosphereTable::cacheKey(in) + ".bin");
    ASSERT_TRUE(std::filesystem::exists(file));
    {  // flip one byte in the payload
        std::fstream f(file, std::ios::in | std::ios::out | std::ios::binary);
        f.seekp(1000);
        char c = 0;
        f.read(&c, 1);
        f.seekp(1000);
        c = static_cast<char>(c ^ 0x5a);
        f.write(&c, 1);
    }
    const AtmosphereTable c =
        AtmosphereTable::loadOrBuild(in, DataDirs{test::configDir(), dir}, &rebuilt);
    EXPECT_TRUE(rebuilt);
    EXPECT_EQ(a.skyRadiance(1, 0.4, 1.0, 0.7), c.skyRadiance(1, 0.4, 1.0, 0.7));

    std::filesystem::resize_file(file, 4000);  // truncated
    AtmosphereTable::loadOrBuild(in, DataDirs{test::configDir(), dir}, &rebuilt);
    EXPECT_TRUE(rebuilt);
    std::filesystem::remove_all(dir);
}

TEST(AtmosphereTableCache, KeyChangesWithEveryInput) {
    const AtmosphereTableInputs base = inputs(23.0);
    const std::string k = AtmosphereTable::cacheKey(base);
    EXPECT_EQ(k.size(), 16u);
    EXPECT_EQ(k, AtmosphereTable::cacheKey(inputs(23.0)));
    AtmosphereTableInputs x = base;
    x.atmosphere.visibility_km = 23.0001;
    EXPECT_NE(k, AtmosphereTable::cacheKey(x));
    x = base;
    x.atmosphere.aerosol = AerosolModel::Urban;
    EXPECT_NE(k, AtmosphereTable::cacheKey(x));
    x = base;
    x.sourceShape[300] *= 1.001;
    EXPECT_NE(k, AtmosphereTable::cacheKey(x));
    x = base;
    x.bands[1].name = "other";
    EXPECT_NE(k, AtmosphereTable::cacheKey(x));
    x = base;
    x.nightSky.continuumRadiance_W_m2_sr_nm[10] = 0.0;
    EXPECT_NE(k, AtmosphereTable::cacheKey(x));
}

TEST(AtmosphereTableCache, UnwritableCacheStillReturnsATable) {
    bool rebuilt = false;
    const AtmosphereTable t = AtmosphereTable::loadOrBuild(
        inputs(60.0), DataDirs{test::configDir(), "/proc/nvs-no-such-dir"}, &rebuilt);
    EXPECT_TRUE(rebuilt);
    EXPECT_GT(t.directTransmittance(0, 0.0), 0.5);
}

}  // namespace
}  // namespace nvs::sky
