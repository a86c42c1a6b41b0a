#pragma once
// Stage MTFs of the IICCD (thesis §6.3, §7.4; docs/design.md §4.5 step 7). Frequencies are in
// cycles per mm in the image plane of the lens, which is the photocathode plane: the II tube has
// unit magnification, so the phosphor and the fibre-optic taper's input face share that scale; the
// CCD sits behind the taper, so its cells appear taper_magnification times larger there.

#include "sim/sensor/camera.h"

namespace nvs::sensor {

// II tube, eq. 6.14: exp(−(ξ/ξc)^n). ξc = 0 means no tube blur.
double mtfIiTube(double rho_cyc_mm, double fc_cyc_mm, double index);
// Fibre-optic bundle, eq. 6.16 (Gaskill's sombrero): |2 J1(π d ρ)/(π d ρ)|, d the core pitch.
double mtfFibre(double rho_cyc_mm, double pitch_mm);
// |sinc(a ξ)| = |sin(π a ξ)/(π a ξ)|, eq. 6.20 for one axis of a cell of width a.
double mtfAperture(double f_cyc_mm, double width_mm);

// The product of the enabled stage MTFs at (ξ, η) [cyc/mm, cathode plane].
double systemMtf(const CameraParams& cam, double fx_cyc_mm, double fy_cyc_mm);

// CCD pixel pitch projected to the cathode plane [mm].
inline double cathodePitchX_mm(const CameraParams& c) {
    return c.pitch_x_um * 1e-3 * c.taper_magnification;
}
inline double cathodePitchY_mm(const CameraParams& c) {
    return c.pitch_y_um * 1e-3 * c.taper_magnification;
}

}  // namespace nvs::sensor
