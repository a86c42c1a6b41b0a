#pragma once
// Time scales for the ephemeris (docs/design.md §3: "conversions to TT/UT1 go through ERFA").
//
// Input is a UTC instant. Two scales are derived from it:
//   UT1 (Earth rotation angle):  UT1 = UTC + DUT1, with DUT1 taken as 0. |DUT1| < 0.9 s by the
//     definition of UTC; 0.9 s of Earth rotation is 0.0038° on the sky, five times below the
//     0.02° accuracy target, so no IERS table is needed.
//   TT (ephemeris argument):     1960 onwards TT = UTC + 32.184 s + ΔAT (ERFA eraDat, the leap
//     second table; held at its last value beyond it). Before 1960 there was no UTC: the
//     instant is taken as UT and TT = UT + ΔT with the polynomials of Espenak & Meeus (NASA
//     "Polynomial expressions for Delta T", 2006), which join the leap-second era within 0.1 s.
// A ΔT error of 1 s moves the Moon by 0.5″, so either choice is far below the target.
//
// Setup parses and validates (SetupError naming the argument); per-frame code only adds
// seconds to an AstroTime.

#include <string>
#include <string_view>

namespace nvs::astro {

// The supported span. The lunar theory (ERFA eraMoon98, a truncated ELP2000-82B) and the ΔT
// model are validated 1950–2100 (tests/sim/astro); outside 1900–2199 the instant is refused.
inline constexpr int kFirstYear = 1900;
inline constexpr int kLastYear = 2199;

struct CalendarInstant {
    int year = 2000, month = 1, day = 1, hour = 0, minute = 0;
    double second = 0.0;
};

// Two-part Julian dates (ERFA convention: jd1 + jd2, jd1 holding the large part).
struct AstroTime {
    double ut1Jd1 = 0.0, ut1Jd2 = 0.0;  // UT1
    double ttJd1 = 0.0, ttJd2 = 0.0;    // TT (used as TDB: |TDB − TT| < 2 ms)
    double deltaT_s = 0.0;              // TT − UT1

    // The same description, dt_s later (per frame: no allocation, no throw).
    AstroTime plusSeconds(double dt_s) const {
        AstroTime t = *this;
        t.ut1Jd2 += dt_s / 86400.0;
        t.ttJd2 += dt_s / 86400.0;
        return t;
    }
};

// Parses an ISO 8601 UTC instant: YYYY-MM-DDTHH:MM[:SS[.fff]] followed by 'Z', '+HH:MM',
// '-HH:MM' or nothing (UTC). A 'T' or a space separates date and time. Offsets are applied.
// Throws SetupError "<what>: ..." on a malformed or out-of-range instant.
CalendarInstant parseIsoUtc(std::string_view text, const std::string& what = "--utc");

// TT − UT1 [s] for a UTC instant, as described above.
double deltaTForUtc_s(const CalendarInstant& utc);

// The time scales for a UTC instant (validated; throws SetupError naming `what`).
AstroTime astroTimeFromUtc(const CalendarInstant& utc, const std::string& what = "--utc");

// The time scales for a UT1 Julian date and an explicit ΔT = TT − UT1 (for comparisons with
// programs that use their own ΔT model).
AstroTime astroTimeFromUt1(double ut1Jd1, double ut1Jd2, double deltaT_s);

}  // namespace nvs::astro
