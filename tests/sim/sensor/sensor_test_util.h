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
// 1230 µA/lm a QE of 0.25 implies), eq. 6.1 unbounded, 50 e read noise, no video noise, no
// halo, no MCP saturation. The mechanism tests
// (loops, blooming, afterglow, the calibration tables) were built on it; the shipped preset's gain
// is anchored to the measured noise instead (photon_transfer_test.cpp, docs/validation.md "Tube
// gain").
inline sensor::CameraParams calibrationTube(sensor::Overrides ov = {}) {
    ov.emplace("mcp.crossover_V", "520.0");
    ov.emplace("mcp.gain_max", "0");                // eq. 6.1 without a ceiling
    ov.emplace("mcp.plate_max_V", "0");             // nor the supply's
    ov.emplace("mcp.detection_efficiency", "1");    // every photoelectron starts a channel
    ov.emplace("ccd.read_noise_e", "50.0");         // the read noise the mechanism tests had
    ov.emplace("video.gain_dc_per_e", "0.003738");  // Table 18-6's image gain at 6 V
    ov.emplace("spectral.qe_peak", "0.25");
    ov.emplace("photocathode.ebi_lm_cm2", "4.097e-11");
    ov.emplace("video.noise_dc", "0.0");
    ov.emplace("halo.enabled", "false");
    ov.emplace("mcp_saturation.enabled", "false");
    return preset("pulnix-ag5745ef3", ov);
}

// The thesis's frame grabber (640 x 480, 8 bit; the thesis, §7.5 and Appendix H §18.2), which
// every frame of its tables went through: a horizontal low-pass exp(−(ξ/ξd)^nd), the whole
// system's MTF (eq. 7.7, exp(−(ξ/6)^0.8), fitted by the thesis to the digitised path C) over
// the preset's path-B MTF (tube, fibre, CCD, fitted to Table 18-2), fitted at Table 18-2's
// frequencies (0.96–23 cyc/mm, rms 0.044): ξd = 21.9 cyc/mm, nd = 0.46. Not part of the camera
// (docs/validation.md, "Tube gain"): tests that compare the chain with the thesis's frames add it.
inline void addThesisGrabber(sensor::Overrides& ov) {
    ov.emplace("mtf.digitiser_fc_cyc_mm", "21.9");
    ov.emplace("mtf.digitiser_index", "0.46");
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
