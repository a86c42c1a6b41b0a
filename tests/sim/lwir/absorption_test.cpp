// Gas absorption and humidity: the Magnus form against the IAPWS steam tables, the path limits,
// and bad coefficient files.
#include "sim/lwir/absorption.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include "sim/core/error.h"
#include "sim/lwir/humidity.h"
#include "tests/sim/lwir/lwir_test_common.h"

namespace nvs::lwir {
namespace {

// Saturation vapour pressure over water, IAPWS-95 (Wagner & Pruß 2002, J. Phys. Chem. Ref. Data
// 31(2), 387–535, Table 13.1): 10 °C 1.2282 kPa, 20 °C 2.3393 kPa, 30 °C 4.2470 kPa; and
// 0.01 °C 611.66 Pa (the triple point). Alduchov & Eskridge quote < 0.4 % error over −40…50 °C.
TEST(LwirHumidity, MagnusMatchesIapwsSteamTables) {
    const struct {
        double t_C, e_Pa;
    } rows[] = {{0.01, 611.66}, {10.0, 1228.2}, {20.0, 2339.3}, {30.0, 4247.0}};
    for (const auto& r : rows) {
        const double e = saturationVapourPressure_Pa(r.t_C + 273.15);
        EXPECT_NEAR(e / r.e_Pa, 1.0, 0.004) << r.t_C << " °C";
    }
}

TEST(LwirHumidity, DewPointAndRelativeHumidityAgree) {
    // RH = e_s(T_d)/e_s(T): a dew point equal to the air temperature is saturation, and the
    // Magnus inverse returns the dew point.
    const double t = 290.0, td = 280.0;
    const double e = vapourPressureFromDewPoint_Pa(td);
    EXPECT_NEAR(dewPointFromVapourPressure_K(e), td, 1e-9);
    EXPECT_NEAR(vapourPressureFromRelativeHumidity_Pa(e / saturationVapourPressure_Pa(t), t), e,
                1e-9);
    EXPECT_DOUBLE_EQ(vapourPressureFromRelativeHumidity_Pa(1.0, t), saturationVapourPressure_Pa(t));
    // Ideal gas: 1 kPa at 293.15 K is 18.015e-3 · 1000 / (8.314 · 293.15) = 7.392 g m⁻³.
    EXPECT_NEAR(vapourDensity_kg_m3(1000.0, 293.15), 7.392e-3, 0.002e-3);
}

TEST(LwirHumidity, BadInputThrows) {
    EXPECT_THROW(vapourPressureFromRelativeHumidity_Pa(-0.1, 290.0), SetupError);
    EXPECT_THROW(vapourPressureFromRelativeHumidity_Pa(1.2, 290.0), SetupError);
    EXPECT_THROW(vapourDensity_kg_m3(-1.0, 290.0), SetupError);
    EXPECT_THROW(dewPointFromVapourPressure_K(0.0), SetupError);
}

AirState air(double e_Pa) {
    AirState a;
    a.temperature_K = 293.15;
    a.vapourPressure_Pa = e_Pa;
    return a;
}

TEST(LwirAbsorption, TransmittanceLimits) {
    // Zero range: nothing absorbs; τ falls with range and with water; 0 ≤ τ ≤ 1 everywhere.
    const Spectral t0 = homogeneousTransmittance(test::data(), air(1500.0), 0.0);
    for (double v : t0)
        EXPECT_DOUBLE_EQ(v, 1.0);
    const Spectral t1 = homogeneousTransmittance(test::data(), air(1500.0), 1000.0);
    const Spectral t2 = homogeneousTransmittance(test::data(), air(1500.0), 2000.0);
    const Spectral tw = homogeneousTransmittance(test::data(), air(3000.0), 1000.0);
    for (int i = 0; i < Grid::kSize; ++i) {
        EXPECT_GE(t1[i], 0.0);
        EXPECT_LT(t1[i], 1.0) << Grid::wavelength_um(i);
        EXPECT_LT(t2[i], t1[i]);
        EXPECT_LT(tw[i], t1[i]);
    }
}

TEST(LwirAbsorption, WindowIsClearerThanTheBandsAroundIt) {
    // The 8–13 µm window lies between the 6.3 µm water band and the 15 µm CO2 band: at 1 km
    // and 15 hPa of vapour, 10 µm transmits more than 7 µm and 15 µm.
    const Spectral t = homogeneousTransmittance(test::data(), air(1500.0), 1000.0);
    const auto at = [&](double um) { return t[static_cast<int>((1e4 / um - 550.0) / 5.0 + 0.5)]; };
    EXPECT_GT(at(10.0), 0.8);
    EXPECT_LT(at(15.0), 0.05);
    EXPECT_LT(at(7.0), 0.2);
}

TEST(LwirAbsorption, NegativeRangeOrVapourThrows) {
    EXPECT_THROW(homogeneousTransmittance(test::data(), air(1000.0), -1.0), SetupError);
    EXPECT_THROW(homogeneousTransmittance(test::data(), air(-5.0), 10.0), SetupError);
}

// A copy of config/lwir in a temporary folder, to break one file of.
std::filesystem::path copyConfig(const char* name) {
    const auto dir = std::filesystem::temp_directory_path() / name;
    std::filesystem::remove_all(dir);
    std::filesystem::create_directories(dir / "lwir");
    for (const auto& e : std::filesystem::directory_iterator(nvs::test::configDir() / "lwir")) {
        std::filesystem::copy_file(e.path(), dir / "lwir" / e.path().filename());
    }
    return dir;
}

std::string loadError(const std::filesystem::path& dir) {
    try {
        AbsorptionData::load(dir);
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

// The 1-based line of the file that starts with `prefix` (0 if none).
int lineOf(const std::filesystem::path& f, const std::string& prefix) {
    std::ifstream in(f);
    std::string line;
    for (int n = 1; std::getline(in, line); ++n) {
        if (line.rfind(prefix, 0) == 0) return n;
    }
    return 0;
}

void replaceInFile(const std::filesystem::path& f, const std::string& from, const std::string& to) {
    std::ifstream in(f);
    std::string s((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    const auto pos = s.find(from);
    ASSERT_NE(pos, std::string::npos) << from;
    s.replace(pos, from.size(), to);
    std::ofstream(f) << s;
}

TEST(LwirAbsorption, MissingCoefficientFileNamesTheFile) {
    const auto dir = copyConfig("nvs_lwir_missing");
    std::filesystem::remove(dir / "lwir" / "band_models_co2_o3.csv");
    EXPECT_NE(loadError(dir).find("band_models_co2_o3.csv"), std::string::npos) << loadError(dir);
}

TEST(LwirAbsorption, MalformedCoefficientNamesFileAndLine) {
    const auto dir = copyConfig("nvs_lwir_malformed");
    const auto f = dir / "lwir" / "h2o_lines_rodgers_walshaw1966.csv";
    const int line = lineOf(f, "1450,1550,632.9");
    ASSERT_GT(line, 0);
    replaceInFile(f, "1450,1550,632.9", "1450,1550,six");
    const std::string why = loadError(dir);
    EXPECT_NE(why.find("h2o_lines_rodgers_walshaw1966.csv:" + std::to_string(line)),
              std::string::npos)
        << why;
}

TEST(LwirAbsorption, NegativeCoefficientNamesFileAndLine) {
    const auto dir = copyConfig("nvs_lwir_negative");
    const auto f = dir / "lwir" / "h2o_continuum_roberts1976.csv";
    const int line = lineOf(f, "t0,1800");
    ASSERT_GT(line, 0);
    replaceInFile(f, "t0,1800", "t0,-1800");
    const std::string why = loadError(dir);
    EXPECT_NE(why.find("h2o_continuum_roberts1976.csv:" + std::to_string(line)), std::string::npos)
        << why;
    EXPECT_NE(why.find("positive"), std::string::npos) << why;
}

TEST(LwirAbsorption, MissingCoefficientOrSourceIsAnError) {
    auto dir = copyConfig("nvs_lwir_nogamma");
    replaceInFile(dir / "lwir" / "h2o_continuum_roberts1976.csv", "gamma,0.002,1\n", "");
    EXPECT_NE(loadError(dir).find("gamma"), std::string::npos);
    dir = copyConfig("nvs_lwir_nosource");
    replaceInFile(dir / "lwir" / "band_models_co2_o3.csv", "# source (co2):", "# from:");
    EXPECT_NE(loadError(dir).find("source"), std::string::npos) << loadError(dir);
}

}  // namespace
}  // namespace nvs::lwir
