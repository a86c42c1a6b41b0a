#include "sim/sensor/mtf.h"

#include <cmath>

#include "sim/core/units.h"

namespace nvs::sensor {

double mtfIiTube(double rho_cyc_mm, double fc_cyc_mm, double index) {
    if (!(fc_cyc_mm > 0.0)) return 1.0;
    return std::exp(-std::pow(std::fabs(rho_cyc_mm) / fc_cyc_mm, index));
}

double mtfFibre(double rho_cyc_mm, double pitch_mm) {
    const double x = kPi * pitch_mm * std::fabs(rho_cyc_mm);
    if (x < 1e-8) return 1.0;
    return std::fabs(2.0 * std::cyl_bessel_j(1.0, x) / x);
}

double mtfAperture(double f_cyc_mm, double width_mm) {
    const double x = kPi * width_mm * f_cyc_mm;
    if (std::fabs(x) < 1e-8) return 1.0;
    return std::fabs(std::sin(x) / x);
}

double systemMtf(const CameraParams& c, double fx, double fy) {
    if (!c.mtf_enabled) return 1.0;
    const double rho = std::hypot(fx, fy);
    double m = mtfIiTube(rho, c.ii_fc_cyc_mm, c.ii_index);
    if (c.fibre_pitch_um > 0.0) m *= mtfFibre(rho, c.fibre_pitch_um * 1e-3);
    if (c.ccd_aperture_mtf) {
        // Eq. 6.20 with the collecting width of a cell: pitch·√fill in each direction.
        const double s = std::sqrt(c.ccd_fill_factor);
        m *= mtfAperture(fx, cathodePitchX_mm(c) * s) * mtfAperture(fy, cathodePitchY_mm(c) * s);
    }
    if (c.digitiser_fc_cyc_mm > 0.0) {
        // The digitiser resamples each video line: a horizontal-only low-pass (thesis §7.5).
        m *= std::exp(-std::pow(std::fabs(fx) / c.digitiser_fc_cyc_mm, c.digitiser_index));
    }
    return m;
}

}  // namespace nvs::sensor
