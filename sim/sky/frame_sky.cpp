#include "sim/sky/frame_sky.h"

#include <cmath>

#include "sim/core/geometry.h"
#include "sim/core/units.h"

namespace nvs::sky {
namespace {

constexpr double kSkyStepZ_deg = 90.0 / (msg::kSkyViewZeniths - 1);
constexpr double kSkyStepA_deg = 180.0 / (msg::kSkyAzimuths - 1);

}  // namespace

msg::FrameSky frameSky(const SkyModel& model, const std::array<int, msg::kBands>& tableBand,
                       const msg::MoonState& moon, double t_sample_s,
                       double lunarSkyScale) noexcept {
    msg::FrameSky s;
    s.t_sample_s = t_sample_s;
    s.moonAz_rad = moon.az_rad;
    s.moonZenith_rad = kPi / 2 - moon.alt_rad;
    s.moonDir_enu = enuFromAzAlt(moon.az_rad, moon.alt_rad);
    s.moonUp = moon.alt_rad > 0.0;
    s.moonAngularRadius_rad = std::asin(kMoonRadius_m / moon.distanceTopocentric_m);
    const AtmosphereTable& t = model.table();
    for (int b = 0; b < msg::kBands; ++b) {
        const int tb = tableBand[static_cast<std::size_t>(b)];
        const double toa = model.moonToa(tb, moon);
        s.moonToa[b] = toa;
        s.moonNormal[b] = s.moonUp ? toa * t.directTransmittance(tb, s.moonZenith_rad) : 0.0;
        s.moonSkyHorizontal[b] = lunarSkyScale * toa * t.diffuseHorizontal(tb, s.moonZenith_rad);
        s.nightSkyHorizontal[b] = t.nightSkyHorizontal(tb);
    }
    // Sky in view on the table's (view zenith, Δφ) nodes: night sky plus the Moon's scattered
    // light (while the Moon is less than 6° below the horizon).
    s.hasSkyRadiance = true;
    for (int b = 0; b < msg::kBands; ++b) {
        const int tb = tableBand[static_cast<std::size_t>(b)];
        float* out = &s.skyRadiance[static_cast<std::size_t>(b) * msg::kSkyNodes];
        for (int iz = 0; iz < msg::kSkyViewZeniths; ++iz) {
            const double vz = iz * kSkyStepZ_deg * (kPi / 180.0);
            for (int ia = 0; ia < msg::kSkyAzimuths; ++ia) {
                double l = t.nightSkyRadiance(tb, vz);
                if (s.moonZenith_rad < 1.6755 && lunarSkyScale != 0.0) {
                    l +=
                        lunarSkyScale * s.moonToa[b] *
                        t.skyRadiance(tb, vz, ia * kSkyStepA_deg * (kPi / 180.0), s.moonZenith_rad);
                }
                out[iz * msg::kSkyAzimuths + ia] = static_cast<float>(l);
            }
        }
    }
    return s;
}

}  // namespace nvs::sky
