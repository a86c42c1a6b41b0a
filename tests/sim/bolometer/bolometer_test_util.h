#pragma once
// Helpers for the microbolometer tests: presets with overrides, uniform blackbody scenes, and
// statistics of raw frames.

#include <cmath>
#include <string>
#include <vector>

#include "sim/bolometer/chain.h"
#include "sim/core/image.h"
#include "sim/core/planck.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::test {

inline bolometer::ThermalCameraParams thermalPreset(const std::string& name,
                                                    const bolometer::Overrides& ov = {}) {
    return bolometer::loadThermalCamera(
        configDir(), (configDir() / "thermal_cameras" / (name + ".toml")).string(), ov);
}

// A uniform blackbody filling the view: its band radiance from Planck's law (sim/core/planck.h,
// checked against σT⁴/π and a direct integration in tests/sim/core).
inline ImageF blackbody(const bolometer::ThermalCameraParams& cam, double T_K) {
    ImageF img(cam.width, cam.height);
    img.fill(static_cast<float>(planckBandRadiance_W_m2_sr(cam.band_lo_um, cam.band_hi_um, T_K)));
    return img;
}

// Runs frames until the shutter is open again after the start-up FFC (and `extra` more).
inline void pastStartupFfc(bolometer::BolometerChain& chain, const ImageF& scene, int extra) {
    while (chain.process(scene.cview()).frozen) {
    }
    for (int i = 0; i < extra; ++i)
        chain.process(scene.cview());
}

inline double meanRaw(const ImageU16& raw) {
    double s = 0.0;
    for (int y = 0; y < raw.height(); ++y)
        for (int x = 0; x < raw.width(); ++x)
            s += raw(x, y);
    return s / (static_cast<double>(raw.width()) * raw.height());
}

// Per-pixel running sums over frames.
struct PixelStats {
    std::vector<double> sum, sum2;
    int n = 0;
    explicit PixelStats(std::size_t px) : sum(px, 0.0), sum2(px, 0.0) {}
    void add(const ImageU16& raw) {
        std::size_t i = 0;
        for (int y = 0; y < raw.height(); ++y)
            for (int x = 0; x < raw.width(); ++x, ++i) {
                const double v = raw(x, y);
                sum[i] += v;
                sum2[i] += v * v;
            }
        ++n;
    }
    // Mean over pixels of each pixel's temporal variance (n − 1).
    double meanTemporalVariance() const {
        double acc = 0.0;
        for (std::size_t i = 0; i < sum.size(); ++i)
            acc += (sum2[i] - sum[i] * sum[i] / n) / (n - 1);
        return acc / static_cast<double>(sum.size());
    }
    // Spatial standard deviation of the temporal means.
    double spatialStdOfMeans() const {
        double m = 0.0, m2 = 0.0;
        for (double s : sum) {
            m += s / n;
            m2 += (s / n) * (s / n);
        }
        const double N = static_cast<double>(sum.size());
        return std::sqrt((m2 - m * m / N) / (N - 1));
    }
    double grandMean() const {
        double m = 0.0;
        for (double s : sum)
            m += s / n;
        return m / static_cast<double>(sum.size());
    }
};

}  // namespace nvs::test
