#include "sim/astro/ephemeris.h"

#include <erfa.h>
#include <erfam.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/core/error.h"
#include "sim/core/units.h"

namespace nvs::astro {

namespace {

constexpr double kAu_m = ERFA_DAU;                           // astronomical unit [m]
constexpr double kLightTimePerAu_day = ERFA_AULT / 86400.0;  // light time for 1 au [day]

double dot(const double a[3], const double b[3]) {
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2];
}
double norm(const double a[3]) {
    return std::sqrt(dot(a, a));
}

// Observed azimuth and airless altitude of a direction p (BCRS axes, from the observer).
void observedAirless(const double p[3], eraASTROM* astrom, double* az, double* alt) {
    double p3[3] = {p[0], p[1], p[2]};
    double rc = 0.0, dc = 0.0;
    eraC2s(p3, &rc, &dc);
    double ri = 0.0, di = 0.0;
    eraAtciq(rc, dc, 0.0, 0.0, 0.0, 0.0, astrom, &ri, &di);
    double aob = 0.0, zob = 0.0, hob = 0.0, dob = 0.0, rob = 0.0;
    eraAtioq(ri, di, astrom, &aob, &zob, &hob, &dob, &rob);
    *az = eraAnp(aob);
    *alt = 0.5 * kPi - zob;
}

// Sæmundsson at standard conditions, h in degrees, result in degrees.
double saemundsson_deg(double h_deg) {
    return (1.02 / 60.0) / std::tan((h_deg + 10.3 / (h_deg + 5.11)) * kRadPerDeg);
}

}  // namespace

double refractionScale(double pressure_hPa, double temperature_C, double relativeHumidity) {
    if (pressure_hPa <= 0.0) return 0.0;
    double a = 0.0, b = 0.0, a0 = 0.0, b0 = 0.0;
    eraRefco(pressure_hPa, temperature_C, relativeHumidity, 0.55, &a, &b);
    eraRefco(1010.0, 10.0, 0.0, 0.55, &a0, &b0);
    return a / a0;
}

double refraction_rad(double altGeometric_rad, double scale) {
    if (scale <= 0.0) return 0.0;
    const double h_deg = altGeometric_rad * kDegPerRad;
    constexpr double kTaperStart_deg = -1.0;
    constexpr double kTaperEnd_deg = -5.0;
    double r_deg = 0.0;
    if (h_deg >= kTaperStart_deg) {
        r_deg = saemundsson_deg(std::min(h_deg, 90.0));
        // At the zenith the formula gives a tiny non-zero value (tan of 90.1°); clamp to ≥ 0.
        r_deg = std::max(r_deg, 0.0);
    } else if (h_deg > kTaperEnd_deg) {
        r_deg = saemundsson_deg(kTaperStart_deg) * (h_deg - kTaperEnd_deg) /
                (kTaperStart_deg - kTaperEnd_deg);
    }
    return r_deg * scale * kRadPerDeg;
}

Ephemeris::Ephemeris(const Site& site) : site_(site) {
    if (!(site.lat_deg >= -90.0 && site.lat_deg <= 90.0))
        throw SetupError("--lat: latitude " + std::to_string(site.lat_deg) +
                         " deg is outside [-90, 90]");
    if (!(site.lon_deg >= -180.0 && site.lon_deg <= 360.0))
        throw SetupError("--lon: longitude " + std::to_string(site.lon_deg) +
                         " deg is outside [-180, 360]");
    if (!(site.height_m >= -500.0 && site.height_m <= 20000.0))
        throw SetupError("--height-m: height " + std::to_string(site.height_m) +
                         " m is outside [-500, 20000]");
    if (!(site.pressure_hPa >= 0.0 && site.pressure_hPa <= 1200.0))
        throw SetupError("--pressure-hpa: pressure " + std::to_string(site.pressure_hPa) +
                         " hPa is outside [0, 1200]");
    if (!(site.temperature_C >= -80.0 && site.temperature_C <= 60.0))
        throw SetupError("--temperature-c: temperature " + std::to_string(site.temperature_C) +
                         " C is outside [-80, 60]");
    if (!(site.relativeHumidity >= 0.0 && site.relativeHumidity <= 1.0))
        throw SetupError("relative humidity must lie in [0, 1]");
    lon_rad_ = eraAnpm(site.lon_deg * kRadPerDeg);
    lat_rad_ = site.lat_deg * kRadPerDeg;
    refractionScale_ =
        refractionScale(site.pressure_hPa, site.temperature_C, site.relativeHumidity);
}

AstrometryContext Ephemeris::prepare(const AstroTime& t) const noexcept {
    AstrometryContext c;
    c.t = t;

    // Step 1: Earth, heliocentric and barycentric (au, au/day).
    eraEpv00(t.ttJd1, t.ttJd2, c.earthHelio, c.earthBary);

    // Step 2: bias-precession-nutation (IAU 2000B), CIP X,Y, CIO locator s, Earth rotation angle.
    double rbpn[3][3];
    eraPnm00b(t.ttJd1, t.ttJd2, rbpn);
    double x = 0.0, y = 0.0;
    eraBpn2xy(rbpn, &x, &y);
    const double s = eraS00(t.ttJd1, t.ttJd2, x, y);
    const double theta = eraEra00(t.ut1Jd1, t.ut1Jd2);

    // Step 3: astrometry context for the observer, no refraction (added in step 6).
    eraApco(t.ttJd1, t.ttJd2, c.earthBary, c.earthHelio[0], x, y, s, theta, lon_rad_, lat_rad_,
            site_.height_m, 0.0, 0.0, 0.0, 0.0, 0.0, &c.astrom);
    return c;
}

SunMoonState Ephemeris::compute(const AstrometryContext& ctx) const noexcept {
    SunMoonState out;
    const AstroTime& t = ctx.t;
    const auto& pvh = ctx.earthHelio;
    const auto& pvb = ctx.earthBary;
    // ERFA takes the context by non-const pointer (it does not write it): a local copy.
    eraASTROM astrom = ctx.astrom;
    // Observer's geocentric position (au, BCRS axes).
    const double obsGeo[3] = {astrom.eb[0] - pvb[0][0], astrom.eb[1] - pvb[0][1],
                              astrom.eb[2] - pvb[0][2]};

    // Step 4a: Sun. Geocentric vector to the Sun = −(Earth heliocentric); topocentric; the Sun's
    // barycentric motion over the 8.3 min light time is ~13 m/s · 500 s, negligible.
    double sunTopo[3];
    for (int i = 0; i < 3; ++i)
        sunTopo[i] = -pvh[0][i] - obsGeo[i];
    observedAirless(sunTopo, &astrom, &out.sun.az_rad, &out.sun.altGeometric_rad);
    out.sun.distance_m = norm(pvh[0]) * kAu_m;

    // Step 4b: Moon, geocentric (au, au/day), then topocentric at the retarded time: the
    // barycentric Moon at t − τ is (Earth + Moon)(t) − (v_E + v_M) τ, observed from the observer
    // at t; eraAtciq then applies the aberration of the observer's barycentric velocity.
    double moonPv[2][3];
    eraMoon98(t.ttJd1, t.ttJd2, moonPv);
    double moonTopo[3];
    for (int i = 0; i < 3; ++i)
        moonTopo[i] = moonPv[0][i] - obsGeo[i];
    const double tau_day = norm(moonTopo) * kLightTimePerAu_day;
    for (int i = 0; i < 3; ++i)
        moonTopo[i] -= (pvb[1][i] + moonPv[1][i]) * tau_day;
    observedAirless(moonTopo, &astrom, &out.moon.az_rad, &out.moon.altGeometric_rad);
    out.moon.distanceGeocentric_m = norm(moonPv[0]) * kAu_m;
    out.moon.distanceTopocentric_m = norm(moonTopo) * kAu_m;

    // Step 5: distances and phase. Moon→Sun = −(Earth heliocentric + Moon geocentric),
    // Moon→Earth = −Moon geocentric; i is the angle between them.
    double moonToSun[3], moonToEarth[3], earthToSun[3];
    for (int i = 0; i < 3; ++i) {
        moonToSun[i] = -(pvh[0][i] + moonPv[0][i]);
        moonToEarth[i] = -moonPv[0][i];
        earthToSun[i] = -pvh[0][i];
    }
    out.moon.sunDistance_m = norm(moonToSun) * kAu_m;
    const double cosI =
        std::clamp(dot(moonToSun, moonToEarth) / (norm(moonToSun) * norm(moonToEarth)), -1.0, 1.0);
    out.moon.phaseAngle_rad = std::acos(cosI);
    out.moon.illuminatedFraction = 0.5 * (1.0 + cosI);
    const double cosE =
        std::clamp(dot(earthToSun, moonPv[0]) / (norm(earthToSun) * norm(moonPv[0])), -1.0, 1.0);
    out.moon.elongation_rad = std::acos(cosE);

    // Step 6: refraction.
    out.sun.alt_rad =
        out.sun.altGeometric_rad + refraction_rad(out.sun.altGeometric_rad, refractionScale_);
    out.moon.alt_rad =
        out.moon.altGeometric_rad + refraction_rad(out.moon.altGeometric_rad, refractionScale_);
    return out;
}

void Ephemeris::stars(const AstrometryContext& ctx, const double* ra_rad, const double* dec_rad,
                      int count, double* az_rad, double* alt_rad) const noexcept {
    // Steps 1–3 are in ctx (prepare); ERFA takes the context by non-const pointer: a copy.
    eraASTROM astrom = ctx.astrom;
    for (int k = 0; k < count; ++k) {
        double ri = 0.0, di = 0.0;
        eraAtciq(ra_rad[k], dec_rad[k], 0.0, 0.0, 0.0, 0.0, &astrom, &ri, &di);
        double aob = 0.0, zob = 0.0, hob = 0.0, dob = 0.0, rob = 0.0;
        eraAtioq(ri, di, &astrom, &aob, &zob, &hob, &dob, &rob);
        az_rad[k] = eraAnp(aob);
        const double altGeometric = 0.5 * kPi - zob;
        alt_rad[k] = altGeometric + refraction_rad(altGeometric, refractionScale_);
    }
}

}  // namespace nvs::astro
