// The night-sky decomposition keeps the thesis's measured spectrum (Appendix G) and its 0.0012 lx.

#include "sim/sky/night_sky.h"

#include <gtest/gtest.h>

#include <cmath>

#include "sim/core/photometry.h"
#include "sim/core/units.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::sky {
namespace {

// V(λ) from the source tree's config/ (loaded once for this file's tests).
const Photometry& photometry() {
    static const Photometry p(test::configDir());
    return p;
}

// 1 R of 557.7 nm photons: 10¹⁰/(4π) s⁻¹ m⁻² sr⁻¹ × 3.5618·10⁻¹⁹ J = 2.8344·10⁻¹⁰ W m⁻² sr⁻¹.
TEST(NightSky, RayleighConversion) {
    EXPECT_NEAR(rayleighToRadiance_W_m2_sr(1.0, 557.7), 2.8344e-10, 0.0005e-10);
}

// Appendix G: "0.0012 lux"; the extracted table integrates to 0.00121 lx (data README).
TEST(NightSky, ComponentsAddUpToAppendixG) {
    const NightSkyModel m = NightSkyModel::load(test::configDir());
    const double measured_lux = kPi * photometry().photometricIntegral(m.measured_W_m2_sr_nm());
    const double model_lux = m.horizontalIlluminance_lux(NightSkyScales{});
    std::printf("Appendix G: %.6f lx; components:", measured_lux);
    double energy = 0.0;
    for (int c = 0; c < kNightSkyComponentCount; ++c) {
        const auto k = static_cast<NightSkyComponent>(c);
        std::printf(" %s %.6f", nightSkyComponentName(k), m.componentIlluminance_lux(k));
        energy += m.component(k).integrate_nm();
        // Every component is a non-negative spectrum.
        for (int i = 0; i < Spectrum::size(); ++i)
            ASSERT_GE(m.component(k)[i], 0.0);
    }
    std::printf("; sum %.6f lx\n", model_lux);
    EXPECT_NEAR(measured_lux, 0.00121, 0.00121 * 0.05);
    EXPECT_NEAR(model_lux, 0.0012, 0.0012 * 0.05);
    // Lines are redistributed inside their 50 nm cell only: energy is conserved exactly and the
    // photopic total within 1 %.
    EXPECT_NEAR(energy, m.measured_W_m2_sr_nm().integrate_nm(),
                1e-9 * m.measured_W_m2_sr_nm().integrate_nm());
    EXPECT_NEAR(model_lux, measured_lux, 0.01 * measured_lux);
    // Starlight is about a quarter of the moonless night sky (thesis §5.3) — here 18 %.
    EXPECT_NEAR(m.componentIlluminance_lux(NightSkyComponent::Starlight) / model_lux, 0.18, 0.02);
    // Outside the line cells (e.g. 700–1100 nm), the sum equals the measured spectrum bin by bin.
    Spectrum sum;
    m.radiance(NightSkyScales{}, sum);
    for (double l = 700.0; l <= 1100.0; l += 10.0)
        EXPECT_NEAR(sum.at_nm(l), m.measured_W_m2_sr_nm().at_nm(l),
                    1e-9 * m.measured_W_m2_sr_nm().max())
            << l;
}

// Each component scales independently: doubling the OI 557.7 line adds exactly its illuminance.
TEST(NightSky, ComponentsScale) {
    const NightSkyModel m = NightSkyModel::load(test::configDir());
    NightSkyScales s;
    const double base = m.horizontalIlluminance_lux(s);
    s[NightSkyComponent::OxygenGreen5577] = 2.0;
    EXPECT_NEAR(m.horizontalIlluminance_lux(s) - base,
                m.componentIlluminance_lux(NightSkyComponent::OxygenGreen5577), 1e-15);
    // A green line near the V peak: 250 R is ~4–5 % of the photopic night sky.
    EXPECT_GT(m.componentIlluminance_lux(NightSkyComponent::OxygenGreen5577) / base, 0.02);
    Spectrum sp;
    m.radiance(s, sp);
    EXPECT_NEAR(kPi * photometry().photometricIntegral(sp), m.horizontalIlluminance_lux(s),
                1e-9 * base);
    // The line sits at 557.7 nm.
    const Spectrum& line = m.component(NightSkyComponent::OxygenGreen5577);
    EXPECT_GT(line.at_nm(558.0), 100.0 * line.at_nm(552.0));
}

}  // namespace
}  // namespace nvs::sky
