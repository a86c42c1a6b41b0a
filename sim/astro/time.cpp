#include "sim/astro/time.h"

#include <erfa.h>

#include <charconv>
#include <cmath>
#include <cstdlib>
#include <string>

#include "sim/core/error.h"

namespace nvs::astro {

namespace {

// Reads exactly n digits at text[pos]; false if they are not all digits.
bool readDigits(std::string_view text, std::size_t pos, std::size_t n, int* out) {
    if (pos + n > text.size()) return false;
    int v = 0;
    for (std::size_t i = pos; i < pos + n; ++i) {
        const char c = text[i];
        if (c < '0' || c > '9') return false;
        v = v * 10 + (c - '0');
    }
    *out = v;
    return true;
}

[[noreturn]] void bad(const std::string& what, std::string_view text, const std::string& why) {
    throw SetupError(what + ": '" + std::string(text) + "' is not a valid UTC instant (" + why +
                     "; expected YYYY-MM-DDTHH:MM[:SS[.fff]][Z|±HH:MM])");
}

// ΔT polynomials of Espenak & Meeus (2006) for 1900–1961, y the decimal year.
double deltaTEspenakMeeus_s(double y) {
    if (y < 1920.0) {
        const double t = y - 1900.0;
        return -2.79 + 1.494119 * t - 0.0598939 * t * t + 0.0061966 * t * t * t -
               0.000197 * t * t * t * t;
    }
    if (y < 1941.0) {
        const double t = y - 1920.0;
        return 21.20 + 0.84493 * t - 0.076100 * t * t + 0.0020936 * t * t * t;
    }
    const double t = y - 1950.0;
    return 29.07 + 0.407 * t - t * t / 233.0 + t * t * t / 2547.0;
}

}  // namespace

CalendarInstant parseIsoUtc(std::string_view text, const std::string& what) {
    CalendarInstant c;
    // Step 1: date "YYYY-MM-DD".
    if (!readDigits(text, 0, 4, &c.year) || text.size() < 10 || text[4] != '-' ||
        !readDigits(text, 5, 2, &c.month) || text[7] != '-' || !readDigits(text, 8, 2, &c.day))
        bad(what, text, "date must be YYYY-MM-DD");
    // Step 2: time "THH:MM[:SS[.fff]]".
    if (text.size() < 16 || (text[10] != 'T' && text[10] != ' ') ||
        !readDigits(text, 11, 2, &c.hour) || text[13] != ':' || !readDigits(text, 14, 2, &c.minute))
        bad(what, text, "time must be THH:MM");
    std::size_t pos = 16;
    if (pos < text.size() && text[pos] == ':') {
        int whole = 0;
        if (!readDigits(text, pos + 1, 2, &whole)) bad(what, text, "seconds must be SS");
        pos += 3;
        double frac = 0.0;
        if (pos < text.size() && text[pos] == '.') {
            std::size_t end = pos + 1;
            while (end < text.size() && text[end] >= '0' && text[end] <= '9')
                ++end;
            if (end == pos + 1) bad(what, text, "no digits after the decimal point");
            // strtod, not std::stod: a long run of zeros underflows (ERANGE), which std::stod
            // reports by throwing std::out_of_range instead of a SetupError. Digits only here,
            // so the result is in [0, 1].
            const std::string digits = "0" + std::string(text.substr(pos, end - pos));
            frac = std::strtod(digits.c_str(), nullptr);
            pos = end;
        }
        c.second = whole + frac;
    }
    // Step 3: zone "Z", "±HH:MM" or nothing.
    int offset_min = 0;
    if (pos < text.size()) {
        if (text[pos] == 'Z' && pos + 1 == text.size()) {
            pos += 1;
        } else if ((text[pos] == '+' || text[pos] == '-') && text.size() == pos + 6 &&
                   text[pos + 3] == ':') {
            int oh = 0, om = 0;
            if (!readDigits(text, pos + 1, 2, &oh) || !readDigits(text, pos + 4, 2, &om) ||
                oh > 14 || om > 59)
                bad(what, text, "bad UTC offset");
            offset_min = (text[pos] == '+' ? 1 : -1) * (oh * 60 + om);
            pos = text.size();
        } else {
            bad(what, text, "unexpected characters after the time");
        }
    }
    // Step 4: range checks (ERFA checks the calendar).
    if (c.hour > 23 || c.minute > 59 || c.second >= 61.0)
        bad(what, text, "hour, minute or second out of range");
    if (c.year < kFirstYear || c.year > kLastYear)
        throw SetupError(what + ": year " + std::to_string(c.year) + " is outside the supported " +
                         "range " + std::to_string(kFirstYear) + "-" + std::to_string(kLastYear));
    double jd1 = 0.0, jd2 = 0.0;
    if (eraCal2jd(c.year, c.month, c.day, &jd1, &jd2) != 0)
        bad(what, text, "no such calendar date");
    int mdays = 31;
    {
        // Days in the month from the next month's first day (handles leap years).
        double n1 = 0.0, n2 = 0.0;
        const int ny = c.month == 12 ? c.year + 1 : c.year;
        const int nm = c.month == 12 ? 1 : c.month + 1;
        eraCal2jd(ny, nm, 1, &n1, &n2);
        double f1 = 0.0, f2 = 0.0;
        eraCal2jd(c.year, c.month, 1, &f1, &f2);
        mdays = static_cast<int>(std::lround(n2 - f2));
    }
    if (c.day > mdays) bad(what, text, "no such calendar date");
    // Step 5: apply the offset (local = UTC + offset) through the Julian date and back.
    if (offset_min != 0) {
        double d1 = 0.0, d2 = 0.0;
        eraCal2jd(c.year, c.month, c.day, &d1, &d2);
        const double secOfDay = c.hour * 3600.0 + c.minute * 60.0 + c.second - offset_min * 60.0;
        double dayShift = std::floor(secOfDay / 86400.0);
        const double rem = secOfDay - dayShift * 86400.0;
        int iy = 0, im = 0, id = 0;
        double fd = 0.0;
        eraJd2cal(d1, d2 + dayShift + 0.5, &iy, &im, &id, &fd);
        c.year = iy;
        c.month = im;
        c.day = id;
        c.hour = static_cast<int>(rem / 3600.0);
        c.minute = static_cast<int>((rem - c.hour * 3600.0) / 60.0);
        c.second = rem - c.hour * 3600.0 - c.minute * 60.0;
        if (c.year < kFirstYear || c.year > kLastYear)
            throw SetupError(what + ": year " + std::to_string(c.year) +
                             " is outside the supported range");
    }
    (void)pos;
    return c;
}

double deltaTForUtc_s(const CalendarInstant& utc) {
    const double fd = (utc.hour * 3600.0 + utc.minute * 60.0 + utc.second) / 86400.0;
    if (utc.year >= 1960) {
        double dat = 0.0;
        // Status 1 ("dubious year", beyond the table's validity) still returns the last value.
        const int j = eraDat(utc.year, utc.month, utc.day, fd, &dat);
        if (j >= 0) return 32.184 + dat;
    }
    double d1 = 0.0, d2 = 0.0;
    eraCal2jd(utc.year, utc.month, utc.day, &d1, &d2);
    const double y = 2000.0 + (d1 + d2 + fd - 2451544.5) / 365.25;
    return deltaTEspenakMeeus_s(y);
}

AstroTime astroTimeFromUtc(const CalendarInstant& utc, const std::string& what) {
    double d1 = 0.0, d2 = 0.0;
    // eraDtf2d("UTC") handles leap-second days; for pre-1960 dates use the plain calendar.
    const char* scale = utc.year >= 1960 ? "UTC" : "UT1";
    const int j =
        eraDtf2d(scale, utc.year, utc.month, utc.day, utc.hour, utc.minute, utc.second, &d1, &d2);
    if (j < 0)
        throw SetupError(what + ": not a valid UTC instant (ERFA eraDtf2d status " +
                         std::to_string(j) + ")");
    // UT1 = UTC (DUT1 = 0, see the header). For a UTC date, the two-part JD from eraDtf2d is
    // already "quasi-JD" with the leap second folded in; the UT1 day fraction equals it.
    return astroTimeFromUt1(d1, d2, deltaTForUtc_s(utc));
}

AstroTime astroTimeFromUt1(double ut1Jd1, double ut1Jd2, double deltaT_s) {
    AstroTime t;
    t.ut1Jd1 = ut1Jd1;
    t.ut1Jd2 = ut1Jd2;
    t.ttJd1 = ut1Jd1;
    t.ttJd2 = ut1Jd2 + deltaT_s / 86400.0;
    t.deltaT_s = deltaT_s;
    return t;
}

}  // namespace nvs::astro
