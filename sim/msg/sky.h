#pragma once
// Messages of the sky side of a frame (docs/design.md §1: astro → sky → render): where the Sun and
// Moon are at an instant (sim/astro fills it), and the frame's sky as the renderer needs it,
// band-integrated in the camera's two bands (sim/sky fills it). Plain values, fixed size: a
// frame copies them, nothing is allocated.

#include <array>

#include "sim/core/geometry.h"

namespace nvs::msg {

// ---- Sun and Moon (sim/astro) ---------------------------------------------------------------
struct SunState {
    double az_rad = 0.0;            // from north through east, [0, 2π)
    double alt_rad = 0.0;           // topocentric, refracted
    double altGeometric_rad = 0.0;  // topocentric, airless
    double distance_m = 0.0;        // Earth centre to Sun centre
};

struct MoonState {
    double az_rad = 0.0;
    double alt_rad = 0.0;
    double altGeometric_rad = 0.0;
    double distanceGeocentric_m =
        0.0;  // Earth centre to Moon centre (docs/design.md §7 distance_km)
    double distanceTopocentric_m = 0.0;  // observer to Moon centre (sets the lunar solid angle)
    double sunDistance_m = 0.0;          // Sun centre to Moon centre
    double phaseAngle_rad = 0.0;         // Sun–Moon–Earth angle
    double elongation_rad = 0.0;         // Sun–Earth–Moon angle (geocentric)
    double illuminatedFraction = 0.0;    // (1 + cos i) / 2
};

struct SunMoonState {
    SunState sun;
    MoonState moon;
};

// ---- The frame's sky (sim/sky → sim/render) -------------------------------------------------
// The renderer's two bands: photoelectron radiance (weight QE(λ) λ/(hc), unit pe s⁻¹ …) and
// band radiance (weight β(λ), unit W …).
inline constexpr int kBandPe = 0;
inline constexpr int kBandW = 1;
inline constexpr int kBands = 2;
using BandValues = std::array<double, kBands>;

// The sky radiance in view is tabulated on the atmosphere table's grid: view zenith 0–90° in
// kSkyViewZeniths steps and azimuth from the Moon's, 0–180°, in kSkyAzimuths steps.
inline constexpr int kSkyViewZeniths = 46;
inline constexpr int kSkyAzimuths = 37;
inline constexpr int kSkyNodes = kSkyViewZeniths * kSkyAzimuths;

// A bright star for one frame: apparent direction and band irradiance at the ground normal to
// the beam, after the atmosphere's direct transmittance [band m⁻²].
inline constexpr int kMaxStars = 128;
struct FrameStar {
    Vec3 dir_enu{0.0, 0.0, 1.0};
    BandValues irradiance{};
};

struct FrameSky {
    double t_sample_s = 0.0;  // the instant it describes (seconds since the scenario epoch)
    bool moonUp = false;
    Vec3 moonDir_enu{0.0, 0.0, 1.0};
    double moonAz_rad = 0.0;
    double moonZenith_rad = 1.5707963267948966;
    double moonAngularRadius_rad = 0.0045;
    BandValues moonNormal{};  // E☾ = E_toa · T(z) normal to the beam at the ground [band m⁻²]
    BandValues moonToa{};     // E_toa [band m⁻²]
    BandValues moonSkyHorizontal{};   // diffuse lunar sky irradiance, horizontal [band m⁻²]
    BandValues nightSkyHorizontal{};  // night-sky irradiance, horizontal [band m⁻²]
    // Sky radiance in view [band m⁻² sr⁻¹] on the (view zenith, Δφ) grid, band-major; without
    // it (hasSkyRadiance false) the sky is isotropic, (E_moon sky + E_night)/π.
    bool hasSkyRadiance = false;
    std::array<float, kBands * kSkyNodes> skyRadiance{};
    int starCount = 0;  // stars above the horizon, drawn where they are in view
    std::array<FrameStar, kMaxStars> stars{};
};

}  // namespace nvs::msg
