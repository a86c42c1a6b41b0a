// The figures of docs/lwir.md: band transmittance and path radiance against range, the sky's
// brightness temperature against zenith angle, clear and overcast, and the clear-sky emittance
// against Idso (1981). Prints tab-separated tables.
#include <cmath>
#include <cstdio>

#include "sim/lwir/band.h"
#include "sim/lwir/humidity.h"
#include "sim/lwir/sky.h"
#include "tests/sim/core/test_paths.h"

using namespace nvs;
using namespace nvs::lwir;

int main() {
    const AbsorptionData data = AbsorptionData::load(test::configDir());
    const BandResponse band = BandResponse::flat(7.5, 13.5);
    std::printf("# 7.5-13.5 um, 15 C air: band transmittance and path radiance [W m-2 sr-1]\n");
    std::printf("range_m");
    const double dews[] = {-5.0, 5.0, 14.0};
    for (double td : dews)
        std::printf("\ttau(Td=%g C)\tLpath(Td=%g C)", td, td);
    std::printf("\n");
    for (double r : {1.0, 10.0, 100.0, 300.0, 1000.0, 3000.0, 10000.0, 20000.0}) {
        std::printf("%g", r);
        for (double td : dews) {
            AirState a;
            a.temperature_K = 288.15;
            a.vapourPressure_Pa = vapourPressureFromDewPoint_Pa(td + 273.15);
            const PathBand p = horizontalPath(data, band, a, r);
            std::printf("\t%.4f\t%.3f", p.transmittance, p.pathRadiance_W_m2_sr);
        }
        std::printf("\n");
    }
    std::printf("\n# 8-14 um sky brightness temperature [K], air 15 C, dew point 5 C\n");
    std::printf("zenith_deg\tclear\tcloud_base_500m_full\tcloud_base_2000m_half\n");
    const BandResponse b814 = BandResponse::flat(8.0, 14.0);
    SkyParams clear;
    clear.vapourPressure_Pa = vapourPressureFromDewPoint_Pa(278.15);
    SkyParams low = clear, mid = clear;
    low.cloudFraction = 1.0;
    low.cloudBase_m = 500.0;
    mid.cloudFraction = 0.5;
    mid.cloudBase_m = 2000.0;
    const auto pc = skyBandRadianceProfile(data, b814, clear, 91);
    const auto pl = skyBandRadianceProfile(data, b814, low, 91);
    const auto pm = skyBandRadianceProfile(data, b814, mid, 91);
    for (int z : {0, 15, 30, 45, 60, 70, 80, 85, 88, 90}) {
        std::printf("%d\t%.1f\t%.1f\t%.1f\n", z, brightnessTemperature_K(b814, pc[z]),
                    brightnessTemperature_K(b814, pl[z]), brightnessTemperature_K(b814, pm[z]));
    }
    std::printf("\n# 8-14 um clear-sky emittance: model and Idso (1981)\n");
    std::printf("T0_K\te0_hPa\tmodel\tIdso\n");
    for (double t : {273.15, 283.15, 293.15, 303.15}) {
        for (double rh : {0.3, 0.6, 0.9}) {
            SkyParams s;
            s.airTemperature_K = t;
            s.vapourPressure_Pa = vapourPressureFromRelativeHumidity_Pa(rh, t);
            const double e = s.vapourPressure_Pa / 100.0;
            const double eps = skyBandEmittance(b814, s, skyBandRadianceProfile(data, b814, s, 91));
            std::printf("%.2f\t%.1f\t%.3f\t%.3f\n", t, e, eps,
                        0.24 + 2.98e-8 * e * e * std::exp(3000.0 / t));
        }
    }
    return 0;
}
