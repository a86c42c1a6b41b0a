#pragma once
// Helpers for the sensor tests: presets with overrides, uniform inputs, ROI statistics.

#include <cmath>
#include <filesystem>
#include <string>

#include "sim/core/image.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::test {

inline sensor::CameraParams preset(const std::string& name, const sensor::Overrides& ov = {}) {
    return sensor::loadCamera(configDir(), (configDir() / "cameras" / (name + ".toml")).string(),
                              ov);
}

// The PULNiX tube as the thesis's radiance calibration (Table 18-6) has it: Vc = 520 V, peak QE
// 0.25, the EBI cathode current of 2.8e-11 lm/cm² at 1800 µA/lm (4.1e-11 lm/cm² at the
// 1230 µA/lm a QE of 0.25 implies), no video noise, no halo, no MCP saturation. The mechanism tests
// (loops, blooming, afterglow, the calibration tables) were built on it; the shipped preset's gain
// is anchored to the measured noise instead (photon_transfer_test.cpp, docs/validation.md "Tube
// gain").
inline sensor::CameraParams calibrationTube(sensor::Overrides ov = {}) {
    ov.emplace("mcp.crossover_V", "520.0");
    ov.emplace("spectral.qe_peak", "0.25");
    ov.emplace("photocathode.ebi_lm_cm2", "4.097e-11");
    ov.emplace("video.noise_dc", "0.0");
    ov.emplace("halo.enabled", "false");
    ov.emplace("mcp_saturation.enabled", "false");
    return preset("pulnix-ag5745ef3", ov);
}

// The Gamma tables the chains of one test executable share (built once per shape step).
inline GammaTableCache& gammaTables() {
    static GammaTableCache tables;
    return tables;
}

struct Stats {
    double mean = 0.0;
    double var = 0.0;
    double sd() const { return std::sqrt(var); }
};

inline Stats roiStats(ImageView<const float> img, int x0, int y0, int w, int h) {
    double s = 0.0, s2 = 0.0;
    for (int y = y0; y < y0 + h; ++y)
        for (int x = x0; x < x0 + w; ++x) {
            const double v = static_cast<double>(img(x, y));
            s += v;
            s2 += v * v;
        }
    const double n = static_cast<double>(w) * h;
    Stats st;
    st.mean = s / n;
    st.var = (s2 - s * s / n) / (n - 1.0);
    return st;
}

inline ImageF uniform(int w, int h, float v) {
    ImageF img(w, h);
    img.fill(v);
    return img;
}

}  // namespace nvs::test
