#pragma once
// Sun and Moon as seen from a site (docs/design.md §4.1), with ERFA (IAU SOFA algorithms).
//
// Per instant:
//   1. Earth's barycentric and heliocentric position/velocity: eraEpv00 (VSOP2000 fit, ~5 km).
//   2. Celestial-to-intermediate frame: IAU 2000B nutation with IAU 2006-compatible bias and
//      precession (eraPnm00b, 1 mas class), CIO locator eraS00; Earth rotation angle eraEra00.
//   3. Observer: eraApco builds the astrometry context (observer's barycentric position and
//      velocity including diurnal motion; polar motion 0, below 0.5″).
//   4. Moon: eraMoon98 (Meeus's truncated ELP2000-82B, ~10″), made topocentric by subtracting the
//      observer's geocentric position (lunar parallax up to 1°), corrected for light time.
//      Sun: Earth's heliocentric position reversed, made topocentric the same way.
//   5. ICRS → CIRS (light deflection, annual and diurnal aberration, precession-nutation):
//      eraAtciq; CIRS → observed azimuth/zenith distance without refraction: eraAtioq with
//      zero refraction constants. This is the *geometric* topocentric altitude.
//   6. Refraction added to the altitude (see refraction_rad below).
// Phase angle i is the Sun–Moon–Earth angle (geocentric), illuminated fraction k = (1+cos i)/2.

// ERFA's header for eraASTROM, which the per-instant context below carries.
#include <erfa.h>

#include "sim/astro/time.h"
#include "sim/msg/sky.h"

namespace nvs::astro {

struct Site {
    double lat_deg = 0.0;           // geodetic latitude, north positive
    double lon_deg = 0.0;           // east positive
    double height_m = 0.0;          // above the WGS84 ellipsoid
    double pressure_hPa = 1013.25;  // 0 switches refraction off
    double temperature_C = 15.0;
    double relativeHumidity = 0.0;  // 0..1
};

// The Sun/Moon state is a message (sim/msg/sky.h): the renderer and the sky read it without
// depending on this module.
using msg::MoonState;
using msg::SunMoonState;
using msg::SunState;

// Refraction R(h) for a geometric (airless) altitude h, so that the apparent altitude is h + R.
//
// Above h = −1°: Sæmundsson's formula (Sky & Telescope 72, 70, 1986; Meeus, Astronomical
// Algorithms, eq. 16.4), the inverse of Bennett's, for 1010 hPa and 10 °C:
//     R = 1.02′ / tan(h + 10.3°/(h + 5.11°))        (h in degrees)
// accurate to about 0.07′ from the zenith to the horizon (34′ there), unlike the A tan z + B
// tan³ z model that ERFA's eraAtioq uses, which fails below ~5°. It is scaled by
// `scale` = refco_A(P, T, RH) / refco_A(1010 hPa, 10 °C, 0) from ERFA eraRefco, which carries
// the pressure, temperature and humidity dependence (≈ P/1010 · 283/(273+T)).
// Below −1° the body cannot be seen from the ground; the refraction there is a convention, not
// physics: it is tapered linearly from R(−1°) to 0 at −5° so that the apparent altitude stays
// continuous and increasing.
double refraction_rad(double altGeometric_rad, double scale);

// ERFA's refraction constant ratio for refraction_rad (0 for P = 0).
double refractionScale(double pressure_hPa, double temperature_C, double relativeHumidity);

// Steps 1–3 for one instant at one site: Earth's heliocentric and barycentric position and
// velocity, and ERFA's astrometry context for the observer. The costly part of an instant
// (eraEpv00, eraPnm00b, eraS00, eraApco); built once by Ephemeris::prepare and shared by the
// Sun/Moon and the stars of that instant.
struct AstrometryContext {
    AstroTime t;
    double earthHelio[2][3] = {};  // au, au/day
    double earthBary[2][3] = {};   // au, au/day
    eraASTROM astrom{};
};

class Ephemeris {
  public:
    // Validates the site (throws SetupError naming the field).
    explicit Ephemeris(const Site& site);

    // Per frame: no allocation, no throw.
    // Steps 1–3 for instant t (for compute and stars below; the same bits as their AstroTime
    // forms, which build it themselves).
    AstrometryContext prepare(const AstroTime& t) const noexcept;
    SunMoonState compute(const AstrometryContext& ctx) const noexcept;
    SunMoonState compute(const AstroTime& t) const noexcept { return compute(prepare(t)); }
    // Stars: apparent (refracted) topocentric azimuth and altitude of `count` stars from their
    // ICRS catalogue directions (ra_rad, dec_rad; proper motion, parallax and radial velocity
    // taken as zero) at t. Steps 1–3 as for the Moon, then eraAtciq (light deflection, annual
    // aberration, precession-nutation), eraAtioq (Earth rotation, diurnal aberration, no
    // refraction) and refraction_rad as in step 6. Per frame: no allocation, no throw.
    void stars(const AstrometryContext& ctx, const double* ra_rad, const double* dec_rad, int count,
               double* az_rad, double* alt_rad) const noexcept;
    void stars(const AstroTime& t, const double* ra_rad, const double* dec_rad, int count,
               double* az_rad, double* alt_rad) const noexcept {
        stars(prepare(t), ra_rad, dec_rad, count, az_rad, alt_rad);
    }

    const Site& site() const { return site_; }

  private:
    Site site_;
    double lon_rad_ = 0.0, lat_rad_ = 0.0;
    double refractionScale_ = 0.0;
};

}  // namespace nvs::astro
