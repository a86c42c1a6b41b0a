// Band radiometry: the grid's band radiance against the exact Planck series, the inverse, and
// the horizontal path's limits (Kirchhoff's law for an isothermal path).
#include "sim/lwir/band.h"

#include <gtest/gtest.h>

#include <fstream>

#include "sim/core/error.h"
#include "sim/core/planck.h"
#include "tests/sim/lwir/lwir_test_common.h"

namespace nvs::lwir {
namespace {

TEST(LwirBand, FlatBandRadianceMatchesThePlanckSeries) {
    // Widger & Woodall's series (sim/core/planck.h) is exact; the 5 cm⁻¹ grid is within 0.1 %.
    for (const auto& [lo, hi] :
         {std::pair{7.5, 13.5}, std::pair{8.0, 14.0}, std::pair{8.0, 12.0}}) {
        const BandResponse b = BandResponse::flat(lo, hi);
        for (double t : {220.0, 273.15, 300.0, 350.0}) {
            const double exact = planckBandRadiance_W_m2_sr(lo, hi, t);
            EXPECT_NEAR(bandRadiance_W_m2_sr(b, t) / exact, 1.0, 1e-3)
                << lo << "-" << hi << " " << t;
            const double dExact = planckBandRadianceDerivative_W_m2_sr_K(lo, hi, t);
            EXPECT_NEAR(bandRadianceDerivative_W_m2_sr_K(b, t) / dExact, 1.0, 2e-3);
        }
    }
}

TEST(LwirBand, BrightnessTemperatureInvertsTheSeries) {
    const BandResponse b = BandResponse::flat(8.0, 14.0);
    for (double t : {200.0, 250.0, 288.15, 320.0, 380.0}) {
        EXPECT_NEAR(brightnessTemperature_K(b, planckBandRadiance_W_m2_sr(8.0, 14.0, t)), t, 0.05);
    }
}

TEST(LwirBand, CsvResponseEqualsFlatBandWhenFlat) {
    const auto f = std::filesystem::temp_directory_path() / "nvs_lwir_response.csv";
    std::ofstream(f) << "# a flat response written by the test\nwavelength_um,response\n"
                        "8.0,1\n14.0,1\n";
    const BandResponse csv = BandResponse::fromCsv(f);
    EXPECT_NEAR(bandRadiance_W_m2_sr(csv, 300.0) / planckBandRadiance_W_m2_sr(8.0, 14.0, 300.0),
                1.0, 1e-3);
}

TEST(LwirBand, BadResponseNamesFileAndLine) {
    const auto f = std::filesystem::temp_directory_path() / "nvs_lwir_bad_response.csv";
    std::ofstream(f) << "wavelength_um,response\n8.0,1\n7.0,1\n";
    try {
        BandResponse::fromCsv(f);
        FAIL() << "no error";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("nvs_lwir_bad_response.csv:3"), std::string::npos)
            << e.what();
    }
    EXPECT_THROW(BandResponse::flat(5.0, 14.0), SetupError);
    EXPECT_THROW(BandResponse::flat(12.0, 8.0), SetupError);
}

AirState humid() {
    AirState a;
    a.temperature_K = 295.0;
    a.vapourPressure_Pa = 2000.0;
    return a;
}

TEST(LwirBand, IsothermalPathIsABlackbody) {
    // Kirchhoff: a blackbody at the air temperature seen through air at that temperature gives
    // B(T_air) at every range, τ B + L_path = B.
    const BandResponse b = BandResponse::flat(7.5, 13.5);
    const double bAir = bandRadiance_W_m2_sr(b, humid().temperature_K);
    for (double r : {1.0, 100.0, 3000.0, 20000.0}) {
        const PathBand p = horizontalPath(test::data(), b, humid(), r);
        EXPECT_NEAR((p.transmittance * bAir + p.pathRadiance_W_m2_sr) / bAir, 1.0, 1e-12) << r;
    }
}

TEST(LwirBand, PathLimits) {
    const BandResponse b = BandResponse::flat(7.5, 13.5);
    const PathBand zero = horizontalPath(test::data(), b, humid(), 0.0);
    EXPECT_DOUBLE_EQ(zero.transmittance, 1.0);
    EXPECT_DOUBLE_EQ(zero.pathRadiance_W_m2_sr, 0.0);
    // τ → 0: a 2000 km path is opaque and radiates as a blackbody at T_air.
    const PathBand far = horizontalPath(test::data(), b, humid(), 2e6);
    EXPECT_LT(far.transmittance, 1e-3);
    EXPECT_NEAR(far.pathRadiance_W_m2_sr / bandRadiance_W_m2_sr(b, humid().temperature_K), 1.0,
                1e-3);
    EXPECT_THROW(horizontalPath(test::data(), b, humid(), -10.0), SetupError);
}

}  // namespace
}  // namespace nvs::lwir
