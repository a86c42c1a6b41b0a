// The RIT scene's spectral reflectances as the GaAs camera sees them under moonlight: grass has
// its red edge (dark in the visible, bright in the NIR), and the camera-band reflectances of the
// four truth panels (Table 9-3's truth frame, signal above bias) come out in the measured order
// and near the measured ratios white : light grey : grass : asphalt = 1 : 0.51 : 0.28 : 0.21.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <string>

#include "sim/core/spectrum.h"
#include "sim/sensor/camera.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace nvs::sensor {
namespace {

Spectrum reflectance(const std::string& name) {
    return loadSpectrumCsv(
               test::sourceDir() / "scenarios" / "rit" / "reflectance" / (name + ".csv"),
               "wavelength_nm", "reflectance_rel")
        .resample();
}

TEST(SceneReflectance, GrassHasItsRedEdge) {
    const Spectrum g = reflectance("grass");
    const auto at = [&](double nm) { return g[static_cast<int>(nm - SpectralGrid::kMin_nm)]; };
    EXPECT_LT(at(670.0), 0.06);             // chlorophyll absorption
    EXPECT_GT(at(800.0), 6.0 * at(670.0));  // the red edge
    EXPECT_GT(at(550.0), at(670.0));        // the green peak
}

TEST(SceneReflectance, TruthPanelRatiosUnderTheGaAsCameraAndMoonlight) {
    const CameraParams cam = test::preset("pulnix-ag5745ef3");
    const Spectrum w = spectrumShape(test::configDir(), "moon") * cameraResponse(cam);
    const auto band = [&](const std::string& m) {
        return integrateProduct_nm(reflectance(m), w) / integrateProduct_nm(Spectrum(1.0), w);
    };
    const double white = band("wht_panel");
    const double truth[3] = {0.51, 0.28, 0.21};  // light grey, grass, asphalt (Table 9-3)
    const char* names[3] = {"lt_gray_panel", "grass", "asphalt"};
    double prev = 1.0;
    for (int i = 0; i < 3; ++i) {
        const double r = band(names[i]) / white;
        std::printf("%-14s %.3f of white (truth %.2f)\n", names[i], r, truth[i]);
        EXPECT_LT(r, prev) << names[i];  // the measured order
        EXPECT_NEAR(r, truth[i], 0.5 * truth[i]) << names[i];
        prev = r;
    }
}

}  // namespace
}  // namespace nvs::sensor
