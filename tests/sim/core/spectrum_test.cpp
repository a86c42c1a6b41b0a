#include "sim/core/spectrum.h"

#include <gtest/gtest.h>

#include <cmath>
#include <fstream>

#include "sim/core/csv.h"
#include "test_paths.h"

namespace nvs {
namespace {

TEST(Spectrum, GridIs350To1100At1nm) {
    EXPECT_EQ(SpectralGrid::kCount, 751);
    EXPECT_EQ(SpectralGrid::wavelength_nm(0), 350.0);
    EXPECT_EQ(SpectralGrid::wavelength_nm(750), 1100.0);
}

TEST(Spectrum, IntegralsOfAnalyticCurves) {
    // Constant 1 over bins [349.5, 1100.5]: 751 nm.
    EXPECT_DOUBLE_EQ(Spectrum(1.0).integrate_nm(), 751.0);
    // A linear ramp integrates exactly under the bin-mean convention.
    const Spectrum ramp = Spectrum::fromFunction([](double l) { return 2.0 * l; });
    EXPECT_NEAR(ramp.integrate_nm(), 1100.5 * 1100.5 - 349.5 * 349.5, 1e-6);
    // Partial ranges count partial bins.
    EXPECT_DOUBLE_EQ(Spectrum(2.0).integrate_nm(500.0, 600.0), 200.0);
    EXPECT_DOUBLE_EQ(Spectrum(2.0).integrate_nm(600.0, 500.0), 200.0);
    EXPECT_DOUBLE_EQ(Spectrum(1.0).integrate_nm(0.0, 5000.0), 751.0);
}

TEST(Spectrum, ArithmeticAndProductIntegral) {
    const Spectrum a = Spectrum::fromFunction([](double l) { return l / 1000.0; });
    const Spectrum b(3.0);
    const Spectrum c = a * b + a - a * 0.5;
    EXPECT_DOUBLE_EQ(c[100], a[100] * 3.5);
    EXPECT_NEAR(integrateProduct_nm(a, b), (a * b).integrate_nm(), 1e-9);
    EXPECT_DOUBLE_EQ(c.max(), c[750]);
}

TEST(Spectrum, InterpolatesBetweenBinCentresAndIsZeroOutside) {
    const Spectrum s = Spectrum::fromFunction([](double l) { return l; });
    EXPECT_DOUBLE_EQ(s.at_nm(500.25), 500.25);
    EXPECT_EQ(s.at_nm(349.0), 0.0);
    EXPECT_EQ(s.at_nm(1100.5), 0.0);
}

TEST(Spectrum, ResampleConservesEnergyFromCoarseAndFineGrids) {
    // Coarse (50 nm) triangle: the piecewise-linear integral is kept exactly.
    TabulatedSpectrum coarse;
    coarse.wavelength_nm = {400, 450, 500, 550, 600};
    coarse.value = {0, 1, 2, 1, 0};
    EXPECT_DOUBLE_EQ(coarse.integrate_nm(), 200.0);
    EXPECT_NEAR(coarse.resample().integrate_nm(), 200.0, 1e-9);
    EXPECT_NEAR(coarse.resample().at_nm(475.0), 1.5, 1e-12);

    // Fine (0.1 nm) narrow line 0.4 nm wide: a point-sampling resampler would lose or
    // double it; bin means keep its area.
    TabulatedSpectrum fine;
    for (int i = 0; i <= 200; ++i) {
        const double l = 585.0 + 0.1 * i;
        fine.wavelength_nm.push_back(l);
        fine.value.push_back(std::fabs(l - 589.3) < 0.2 ? 10.0 : 0.0);
    }
    EXPECT_NEAR(fine.resample().integrate_nm(), fine.integrate_nm(), 1e-9);
    EXPECT_NEAR(fine.integrate_nm(), 4.0, 1e-9);
}

TEST(Spectrum, ClampHoldsEndValues) {
    TabulatedSpectrum t;
    t.wavelength_nm = {500, 600};
    t.value = {1, 3};
    const Spectrum z = t.resample(Extrapolation::Zero);
    const Spectrum c = t.resample(Extrapolation::Clamp);
    EXPECT_EQ(z.at_nm(400.0), 0.0);
    EXPECT_DOUBLE_EQ(c.at_nm(400.0), 1.0);
    EXPECT_DOUBLE_EQ(c.at_nm(1000.0), 3.0);
    EXPECT_NEAR(z.integrate_nm(), 200.0, 1e-9);
}

TEST(Spectrum, UnitSuffixesConvertToSiPerNm) {
    std::string unit;
    const FileLoc loc{"t.csv", 1, 0};
    EXPECT_DOUBLE_EQ(unitFactorFromColumnName("radiance_W_cm-2_sr-1_um-1", &unit, loc), 1e4 * 1e-3);
    EXPECT_EQ(unit, "W m-2 sr-1 nm-1");
    EXPECT_DOUBLE_EQ(unitFactorFromColumnName("response_rel", &unit, loc), 1.0);
    EXPECT_EQ(unit, "1");
    EXPECT_DOUBLE_EQ(unitFactorFromColumnName("reflectance_pct", &unit, loc), 0.01);
    EXPECT_DOUBLE_EQ(unitFactorFromColumnName("wavelength_um", &unit, loc), 1e-6);
    EXPECT_EQ(unit, "m");
    EXPECT_DOUBLE_EQ(unitFactorFromColumnName("irradiance_W_m-2_nm-1", &unit, loc), 1.0);
    EXPECT_DOUBLE_EQ(unitFactorFromColumnName("irradiance_derived_W_m-2_um-1", &unit, loc), 1e-3);
    EXPECT_EQ(unit, "W m-2 nm-1");
    EXPECT_DOUBLE_EQ(unitFactorFromColumnName("luminous_efficiency_V_rel", &unit, loc), 1.0);
    EXPECT_EQ(unit, "1");
    EXPECT_THROW(unitFactorFromColumnName("x_furlongs", &unit, loc), SetupError);
    EXPECT_THROW(unitFactorFromColumnName("nounit", &unit, loc), SetupError);
}

// The thesis's night-sky table (Appendix G) in W cm⁻² sr⁻¹ µm⁻¹ loads as W m⁻² sr⁻¹ nm⁻¹:
// its irradiance column (derived there as L·1e4·π in W m⁻² µm⁻¹) must agree after conversion.
TEST(Spectrum, LoadsThesisNightSkyWithUnitConversion) {
    const auto path = test::thesisData("night_sky_spectrum.csv");
    const TabulatedSpectrum l = loadSpectrumCsv(path, "wavelength_um", "radiance_W_cm-2_sr-1_um-1");
    const TabulatedSpectrum m =
        loadSpectrumCsv(path, "wavelength_um", "irradiance_derived_W_m-2_um-1");
    EXPECT_EQ(l.unit, "W m-2 sr-1 nm-1");
    EXPECT_EQ(m.unit, "W m-2 nm-1");
    ASSERT_EQ(l.value.size(), 21u);
    EXPECT_DOUBLE_EQ(l.wavelength_nm.front(), 350.0);
    for (std::size_t i = 0; i < l.value.size(); ++i) {
        EXPECT_NEAR(m.value[i] / (l.value[i] * 3.14159265358979), 1.0, 1e-3) << i;
    }
}

TEST(Spectrum, LoaderRejectsBadTables) {
    const auto dir = std::filesystem::temp_directory_path();
    const auto write = [&](const char* name, const char* text) {
        std::ofstream(dir / name) << text;
        return dir / name;
    };
    EXPECT_THROW(loadSpectrumCsv(write("nvs_dec.csv", "wavelength_nm,v_rel\n500,1\n400,2\n"),
                                 "wavelength_nm", "v_rel"),
                 SetupError);
    EXPECT_THROW(loadSpectrumCsv(write("nvs_wl.csv", "wavelength_W,v_rel\n500,1\n600,2\n"),
                                 "wavelength_W", "v_rel"),
                 SetupError);
    EXPECT_THROW(loadSpectrumCsv(dir / "nvs_missing.csv", "wavelength_nm", "v_rel"), SetupError);
}

}  // namespace
}  // namespace nvs
