#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <ctime>

#include "drivers/serial/serial.h"

namespace nvs::drivers {

namespace {

int hexValue(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    return -1;
}

// Splits the body (between '$' and '*') into comma-separated fields, in place.
int splitFields(char* body, char** fields, int maxFields) {
    int n = 0;
    fields[n++] = body;
    for (char* p = body; *p != '\0'; ++p) {
        if (*p == ',') {
            *p = '\0';
            if (n == maxFields) return -1;
            fields[n++] = p + 1;
        }
    }
    return n;
}

bool parseNumber(const char* s, double* v) {
    if (*s == '\0') return false;
    char* end = nullptr;
    *v = std::strtod(s, &end);
    return *end == '\0' && std::isfinite(*v);
}

// A field's verdict: well formed and in range, not a number of its shape, or well formed but
// outside the protocol's range (counted apart: NmeaCounters::outOfRange).
enum class Field { Ok, Malformed, OutOfRange };

// "ddmm.mmmm" / "dddmm.mmmm" and a hemisphere letter → signed degrees: latitude within ±90,
// longitude within ±180, minutes below 60 (NMEA 0183 v4.11 §6.3: llll.ll, yyyyy.yy).
Field parseLatLon(const char* value, const char* hemi, bool lat, double* deg) {
    double v = 0.0;
    if (!parseNumber(value, &v)) return Field::Malformed;
    const bool south = std::strcmp(hemi, lat ? "S" : "W") == 0;
    if (!south && std::strcmp(hemi, lat ? "N" : "E") != 0) return Field::Malformed;
    if (v < 0.0) return Field::OutOfRange;
    const double d = std::floor(v / 100.0);
    const double m = v - d * 100.0;
    const double out = d + m / 60.0;
    if (m >= 60.0 || (lat ? out > 90.0 : out > 180.0)) return Field::OutOfRange;
    *deg = south ? -out : out;
    return Field::Ok;
}

bool digitsAt(const char* s, int n, int* v) {
    *v = 0;
    for (int i = 0; i < n; ++i) {
        if (s[i] < '0' || s[i] > '9') return false;
        *v = *v * 10 + (s[i] - '0');
    }
    return true;
}

// "hhmmss" or "hhmmss.sss" → UTC seconds since midnight, in [0, 86401) (second 60: a leap
// second). Read digit by digit: no conversion of an unbounded number to an integer.
Field parseTimeOfDay(const char* s, double* t_s) {
    int hh = 0, mm = 0, whole = 0;
    if (std::strlen(s) < 6 || !digitsAt(s, 2, &hh) || !digitsAt(s + 2, 2, &mm) ||
        !digitsAt(s + 4, 2, &whole)) {
        return Field::Malformed;
    }
    double frac = 0.0;
    if (s[6] != '\0') {
        if (s[6] != '.' || s[7] == '\0') return Field::Malformed;
        for (const char* p = s + 7; *p != '\0'; ++p) {
            if (*p < '0' || *p > '9') return Field::Malformed;
        }
        frac = std::strtod(s + 6, nullptr);  // ".sss": digits only, in [0, 1]
    }
    if (hh > 23 || mm > 59 || whole > 60) return Field::OutOfRange;
    *t_s = hh * 3600.0 + mm * 60.0 + whole + frac;
    return Field::Ok;
}

bool leapYear(int y) {
    return (y % 4 == 0 && y % 100 != 0) || y % 400 == 0;
}

// "ddmmyy" → Unix seconds of that day's midnight UTC; the day must exist in its month (no
// 31 February; 29 February only in a leap year). Two-digit years: 1980–2079.
Field parseDate(const char* s, double* midnight_unix_s) {
    int dd = 0, mo = 0, yy = 0;
    if (std::strlen(s) != 6 || !digitsAt(s, 2, &dd) || !digitsAt(s + 2, 2, &mo) ||
        !digitsAt(s + 4, 2, &yy)) {
        return Field::Malformed;
    }
    const int year = yy < 80 ? 2000 + yy : 1900 + yy;
    static constexpr int kDays[12] = {31, 28, 31, 30, 31, 30, 31, 31, 30, 31, 30, 31};
    if (mo < 1 || mo > 12) return Field::OutOfRange;
    const int monthDays = kDays[mo - 1] + (mo == 2 && leapYear(year) ? 1 : 0);
    if (dd < 1 || dd > monthDays) return Field::OutOfRange;
    std::tm tm{};
    tm.tm_mday = dd;
    tm.tm_mon = mo - 1;
    tm.tm_year = year - 1900;
    *midnight_unix_s = static_cast<double>(timegm(&tm));
    return Field::Ok;
}

}  // namespace

bool NmeaParser::parseSentence(const char* s, std::size_t len, NmeaSentence* out) noexcept {
    // "$" body "*" hh ; checksum = XOR of every body character.
    if (len < 4 || (s[0] != '$' && s[0] != '!') || len > kMax) {
        ++counters_.malformed;
        return false;
    }
    const char* star = static_cast<const char*>(std::memchr(s, '*', len));
    if (star == nullptr || static_cast<std::size_t>(star - s) + 3 != len) {
        ++counters_.malformed;
        return false;
    }
    std::uint8_t sum = 0;
    for (const char* p = s + 1; p < star; ++p)
        sum = static_cast<std::uint8_t>(sum ^ static_cast<std::uint8_t>(*p));
    const int hi = hexValue(star[1]), lo = hexValue(star[2]);
    if (hi < 0 || lo < 0) {
        ++counters_.malformed;
        return false;
    }
    if (sum != hi * 16 + lo) {
        ++counters_.badChecksum;
        return false;
    }
    char body[kMax + 1];
    const std::size_t bodyLen = static_cast<std::size_t>(star - s - 1);
    std::memcpy(body, s + 1, bodyLen);
    body[bodyLen] = '\0';
    char* f[32];
    const int n = splitFields(body, f, 32);
    if (n < 1 || std::strlen(f[0]) != 5) {
        ++counters_.malformed;
        return false;
    }
    const char* type = f[0] + 2;  // after the two-letter talker (GP, GN, HE, …)
    NmeaSentence r;
    Field verdict = Field::Ok;
    // The worse of two verdicts: a malformed field outweighs an out-of-range one.
    const auto note = [&verdict](Field v) {
        if (v == Field::Malformed || (v == Field::OutOfRange && verdict == Field::Ok)) verdict = v;
    };
    if (std::strcmp(type, "GGA") == 0) {
        // GGA: time, lat, N/S, lon, E/W, quality, sats, hdop, alt, M, geoid sep, M, …
        double quality = 0, alt = 0, sep = 0;
        if (n < 12 || !parseNumber(f[6], &quality)) {
            ++counters_.malformed;
            return false;
        }
        note(parseTimeOfDay(f[1], &r.timeOfDay_s));
        r.type = NmeaSentence::Type::Gga;
        r.valid = quality > 0;
        if (r.valid) {
            note(parseLatLon(f[2], f[3], true, &r.lat_deg));
            note(parseLatLon(f[4], f[5], false, &r.lon_deg));
            if (!parseNumber(f[9], &alt)) note(Field::Malformed);
            if (!parseNumber(f[11], &sep)) sep = 0.0;
            r.alt_m = alt + sep;
        }
    } else if (std::strcmp(type, "RMC") == 0) {
        // RMC: time, status, lat, N/S, lon, E/W, speed, course, date ddmmyy, …
        if (n < 10) {
            ++counters_.malformed;
            return false;
        }
        note(parseTimeOfDay(f[1], &r.timeOfDay_s));
        r.type = NmeaSentence::Type::Rmc;
        r.valid = std::strcmp(f[2], "A") == 0;
        if (r.valid) {
            double midnight = 0.0;
            note(parseLatLon(f[3], f[4], true, &r.lat_deg));
            note(parseLatLon(f[5], f[6], false, &r.lon_deg));
            note(parseDate(f[9], &midnight));
            r.utc_unix_s = midnight + r.timeOfDay_s;
        }
    } else if (std::strcmp(type, "HDT") == 0) {
        // HDT: true heading in degrees, [0, 360].
        if (n < 2 || !parseNumber(f[1], &r.heading_deg)) {
            note(Field::Malformed);
        } else if (r.heading_deg < 0.0 || r.heading_deg > 360.0) {
            note(Field::OutOfRange);
        }
        r.type = NmeaSentence::Type::Hdt;
        r.valid = true;
    } else {
        ++counters_.unsupported;
        return false;
    }
    if (verdict != Field::Ok) {
        ++(verdict == Field::Malformed ? counters_.malformed : counters_.outOfRange);
        return false;
    }
    ++counters_.sentences;
    *out = r;
    return true;
}

bool NmeaParser::push(std::uint8_t byte, NmeaSentence* out) noexcept {
    const char c = static_cast<char>(byte);
    if (c == '$' || c == '!') {
        if (inSentence_ && len_ > 0) ++counters_.malformed;  // cut short by a new start
        inSentence_ = true;
        len_ = 0;
        buf_[len_++] = c;
        return false;
    }
    if (!inSentence_) return false;
    if (c == '\r' || c == '\n') {
        inSentence_ = false;
        return parseSentence(buf_, len_, out);
    }
    if (len_ >= kMax || byte < 0x20 || byte > 0x7e) {
        ++counters_.malformed;
        inSentence_ = false;
        return false;
    }
    buf_[len_++] = c;
    return false;
}

std::string nmeaWithChecksum(const std::string& body) {
    std::uint8_t sum = 0;
    for (std::size_t i = 1; i < body.size(); ++i)
        sum = static_cast<std::uint8_t>(sum ^ static_cast<std::uint8_t>(body[i]));
    char tail[8];
    std::snprintf(tail, sizeof tail, "*%02X\r\n", sum);
    return body + tail;
}

}  // namespace nvs::drivers
