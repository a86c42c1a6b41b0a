#include "sim/lwir/humidity.h"

#include <cmath>
#include <string>

#include "sim/core/error.h"

namespace nvs::lwir {
namespace {

// Alduchov & Eskridge (1996), AERK coefficients.
constexpr double kA_Pa = 610.94;
constexpr double kB = 17.625;
constexpr double kC_degC = 243.04;
constexpr double kKelvinOffset = 273.15;

void requireTemperature(double t_K, const char* what) {
    if (!(t_K > 150.0 && t_K < 350.0)) {
        throw SetupError(std::string("lwir: ") + what + " " + std::to_string(t_K) +
                         " K is outside 150–350 K");
    }
}

}  // namespace

double saturationVapourPressure_Pa(double temperature_K) {
    requireTemperature(temperature_K, "temperature");
    const double t = temperature_K - kKelvinOffset;
    return kA_Pa * std::exp(kB * t / (t + kC_degC));
}

double vapourPressureFromDewPoint_Pa(double dewPoint_K) {
    requireTemperature(dewPoint_K, "dew point");
    return saturationVapourPressure_Pa(dewPoint_K);
}

double vapourPressureFromRelativeHumidity_Pa(double relativeHumidity, double airTemperature_K) {
    if (!(relativeHumidity >= 0.0 && relativeHumidity <= 1.0)) {
        throw SetupError("lwir: relative humidity " + std::to_string(relativeHumidity) +
                         " is outside 0–1");
    }
    return relativeHumidity * saturationVapourPressure_Pa(airTemperature_K);
}

double dewPointFromVapourPressure_K(double vapourPressure_Pa) {
    if (!(vapourPressure_Pa > 0.0)) {
        throw SetupError("lwir: vapour pressure " + std::to_string(vapourPressure_Pa) +
                         " Pa must be positive");
    }
    // ln(e/A) = B t/(t + C)  →  t = C ln(e/A) / (B − ln(e/A)).
    const double g = std::log(vapourPressure_Pa / kA_Pa);
    return kC_degC * g / (kB - g) + kKelvinOffset;
}

double vapourDensity_kg_m3(double vapourPressure_Pa, double temperature_K) {
    if (!(vapourPressure_Pa >= 0.0)) {
        throw SetupError("lwir: vapour pressure " + std::to_string(vapourPressure_Pa) +
                         " Pa is negative");
    }
    requireTemperature(temperature_K, "temperature");
    return vapourPressure_Pa * kMolarMassWater_kg_mol / (kGasConstant_J_mol_K * temperature_K);
}

}  // namespace nvs::lwir
