#pragma once
// Helpers for the sensor tests: presets with overrides, uniform inputs, ROI statistics.

#include <cmath>
#include <filesystem>
#include <string>

#include "sim/core/image.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"

namespace nvs::test {

inline std::filesystem::path thesisData(const char* file) {
    return std::filesystem::path(NVS_TEST_DATA_DIR) / "thesis" / file;
}

inline sensor::CameraParams preset(const std::string& name, const sensor::Overrides& ov = {}) {
    return sensor::loadCamera(
        (std::filesystem::path(NVS_SOURCE_DIR) / "config" / "cameras" / (name + ".toml")).string(),
        ov);
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
