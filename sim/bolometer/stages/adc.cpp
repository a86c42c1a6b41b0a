#include "sim/bolometer/stages/adc.h"

#include <cmath>

#include "sim/bolometer/camera.h"
#include "sim/core/simd.h"

namespace nvs::bolometer {

void AdcParams::read(const Reader& root) {
    const Reader a = root.sub("adc");
    adc_bits = a.get<int>("bits", adc_bits);
    require(adc_bits >= 8 && adc_bits <= 16, a, "bits", "must be in 8 … 16");
    counts_per_K = positive(a, "counts_per_K", counts_per_K);
    adc_reference_K = positive(a, "reference_K", adc_reference_K);
    level_counts = nonNegative(a, "level_counts", level_counts);
    require(level_counts <= std::ldexp(1.0, adc_bits) - 1.0, a, "level_counts",
            "must be within the ADC's range");
}

AdcStage::AdcStage(const ThermalCameraParams& cam) : max_((1 << cam.adc_bits) - 1) {
    const double k = cam.counts_per_K / cam.voltsPerSceneK(cam.adc_reference_K);
    const double vRef = cam.responsivity_V_W *
                        cam.wattsPerRadiance(cam.f_number, cam.optics_transmission) *
                        cam.bandRadiance_W_m2_sr(cam.adc_reference_K);
    k_ = static_cast<float>(k);
    offset_ = static_cast<float>(cam.level_counts - k * vRef);
}

NVS_SIMD_CLONES int AdcStage::applyRow(const float* v, std::uint16_t* r, int n,
                                       std::uint32_t& sum_counts) const noexcept {
    // q = v·k + offset + ½, clamped to [0, top], then truncated: the nearest count (the clamp
    // first, so that truncation is floor; no libm floor in the loop, which then vectorises).
    // Branch-free (bitwise | of the comparisons, selects), so that the loop vectorises.
    const float top = static_cast<float>(max_), beyond = top + 1.0f;
    const float k = k_, offset = offset_;
    int c = 0;
    std::uint32_t sum = 0;
    for (int x = 0; x < n; ++x) {
        float q = v[x] * k + offset + 0.5f;
        c += static_cast<int>((q < 0.0f) | (q >= beyond));
        q = q < 0.0f ? 0.0f : q;
        q = q > top ? top : q;
        const std::uint16_t u = static_cast<std::uint16_t>(static_cast<int>(q));
        r[x] = u;
        sum += u;
    }
    sum_counts += sum;
    return c;
}

std::int64_t AdcStage::apply(ImageView<const float> volts, ImageView<std::uint16_t> raw,
                             double& sum_counts) const noexcept {
    std::int64_t clipped = 0;
    double sum = 0.0;
    for (int y = 0; y < volts.height(); ++y) {
        std::uint32_t rowSum = 0;
        clipped += applyRow(volts.row(y), raw.row(y), volts.width(), rowSum);
        sum += rowSum;
    }
    sum_counts = sum;
    return clipped;
}

}  // namespace nvs::bolometer
