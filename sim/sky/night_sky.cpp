#include "sim/sky/night_sky.h"

#include <cmath>
#include <string>

#include "sim/core/photometry.h"
#include "sim/core/planck.h"
#include "sim/core/units.h"
#include "sim/sky/solar.h"

namespace nvs::sky {

namespace {

struct Line {
    NightSkyComponent component;
    double wavelength_nm;
    double intensity_R;
};
constexpr Line kLines[] = {
    {NightSkyComponent::OxygenGreen5577, 557.7, 250.0},
    {NightSkyComponent::OxygenRed6300, 630.0, 60.0},
    {NightSkyComponent::SodiumD, 589.3, 50.0},
};
constexpr double kStarlight_lux = 2.2e-4;
constexpr double kStarlightColourTemperature_K = 4500.0;
constexpr double kZodiacal_lux = 2.0e-4;
constexpr double kLineSigma_nm = 0.5;  // instrumental width; airglow lines are < 0.01 nm wide
constexpr double kLineBox_nm = 50.0;   // Appendix G's sampling

// Bin means of a unit-area Gaussian on the grid (bins [λ−0.5, λ+0.5]).
Spectrum gaussianLine(double centre_nm, double sigma_nm) {
    return Spectrum::fromFunction([&](double l) {
        const double a = (l - 0.5 - centre_nm) / (sigma_nm * std::sqrt(2.0));
        const double b = (l + 0.5 - centre_nm) / (sigma_nm * std::sqrt(2.0));
        return 0.5 * (std::erf(b) - std::erf(a)) / SpectralGrid::kStep_nm;
    });
}

// Unit-area box of width w centred on c, as bin means (partial bins by overlap).
Spectrum box(double centre_nm, double width_nm) {
    const double lo = centre_nm - width_nm / 2, hi = centre_nm + width_nm / 2;
    return Spectrum::fromFunction([&](double l) {
        const double overlap = std::max(0.0, std::min(hi, l + 0.5) - std::max(lo, l - 0.5));
        return overlap / width_nm / SpectralGrid::kStep_nm;
    });
}

// A component with the given spectral shape scaled to an illuminance π ∫L V K_m.
Spectrum scaledToLux(const Photometry& photometry, Spectrum shape, double lux) {
    return shape * (lux / (kPi * photometry.photometricIntegral(shape)));
}

}  // namespace

const char* nightSkyComponentName(NightSkyComponent c) {
    switch (c) {
        case NightSkyComponent::OxygenGreen5577:
            return "oi_557_7";
        case NightSkyComponent::OxygenRed6300:
            return "oi_630_0";
        case NightSkyComponent::SodiumD:
            return "na_d";
        case NightSkyComponent::OhAndContinuum:
            return "oh_and_continuum";
        case NightSkyComponent::Starlight:
            return "starlight";
        case NightSkyComponent::Zodiacal:
            return "zodiacal";
    }
    return "?";
}

double rayleighToRadiance_W_m2_sr(double intensity_R, double wavelength_nm) {
    const double photons = intensity_R * 1e10 / (4.0 * kPi);
    return photons * kPlanck_J_s * kSpeedOfLight_m_s / (wavelength_nm * kMPerNm);
}

NightSkyModel NightSkyModel::load(const std::filesystem::path& configDir) {
    NightSkyModel m;
    const Photometry photometry(configDir);
    const auto path = configDir / "spectra" / "night_sky_thesis_appendix_g.csv";
    const TabulatedSpectrum g = loadSpectrumCsv(path, "wavelength_um", "radiance_W_cm-2_sr-1_um-1");
    // Clamp: the first grid bin [349.5, 350.5] nm starts half a nanometre before the table.
    m.measured_ = g.resample(Extrapolation::Clamp);

    Spectrum residual = m.measured_;
    // Step 1: lines, energy from their intensity, taken out of the 50 nm cell around them.
    for (const Line& l : kLines) {
        const double e = rayleighToRadiance_W_m2_sr(l.intensity_R, l.wavelength_nm);
        m.components_[static_cast<int>(l.component)] =
            gaussianLine(l.wavelength_nm, kLineSigma_nm) * e;
        residual -= box(l.wavelength_nm, kLineBox_nm) * e;
    }
    // Step 2: continua with published illuminances and assumed shapes.
    Spectrum star = scaledToLux(
        photometry, planckRadiance_W_m2_sr_nm(kStarlightColourTemperature_K), kStarlight_lux);
    Spectrum zodi = scaledToLux(photometry, loadSolarSpectrum_W_m2_nm(configDir), kZodiacal_lux);
    residual -= star;
    residual -= zodi;
    m.components_[static_cast<int>(NightSkyComponent::Starlight)] = star;
    m.components_[static_cast<int>(NightSkyComponent::Zodiacal)] = zodi;
    // Step 3: what is left is OH Meinel emission and the airglow continuum.
    for (int i = 0; i < Spectrum::size(); ++i) {
        if (residual[i] < -1e-6 * m.measured_.max())
            throw SetupError(FileLoc{path.string(), 0, 0},
                             "night-sky decomposition leaves a negative residual at " +
                                 std::to_string(SpectralGrid::wavelength_nm(i)) + " nm");
        residual[i] = std::max(residual[i], 0.0);
    }
    m.components_[static_cast<int>(NightSkyComponent::OhAndContinuum)] = residual;
    for (int c = 0; c < kNightSkyComponentCount; ++c)
        m.componentLux_[c] = kPi * photometry.photometricIntegral(m.components_[c]);
    return m;
}

void NightSkyModel::radiance(const NightSkyScales& s, Spectrum& out) const noexcept {
    for (int i = 0; i < Spectrum::size(); ++i) {
        double v = 0.0;
        for (int c = 0; c < kNightSkyComponentCount; ++c)
            v += s.scale[c] * components_[c][i];
        out[i] = v;
    }
}

double NightSkyModel::horizontalIlluminance_lux(const NightSkyScales& s) const noexcept {
    double e = 0.0;
    for (int c = 0; c < kNightSkyComponentCount; ++c)
        e += s.scale[c] * componentLux_[c];
    return e;
}

}  // namespace nvs::sky
