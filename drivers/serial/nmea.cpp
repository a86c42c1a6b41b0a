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

// "ddmm.mmmm" / "dddmm.mmmm" and a hemisphere letter → signed degrees.
bool parseLatLon(const char* value, const char* hemi, bool lat, double* deg) {
    double v = 0.0;
    if (!parseNumber(value, &v) || v < 0.0) return false;
    const double d = std::floor(v / 100.0);
    const double m = v - d * 100.0;
    if (m >= 60.0) return false;
    double out = d + m / 60.0;
    if (lat ? out > 90.0 : out > 180.0) return false;
    if (std::strcmp(hemi, lat ? "S" : "W") == 0) {
        out = -out;
    } else if (std::strcmp(hemi, lat ? "N" : "E") != 0) {
        return false;
    }
    *deg = out;
    return true;
}

bool parseTimeOfDay(const char* s, double* t_s) {
    double v = 0.0;
    if (std::strlen(s) < 6 || !parseNumber(s, &v)) return false;
    const int hh = static_cast<int>(v / 10000.0);
    const int mm = static_cast<int>(v / 100.0) % 100;
    const double ss = v - hh * 10000.0 - mm * 100.0;
    if (hh > 23 || mm > 59 || ss >= 61.0) return false;
    *t_s = hh * 3600.0 + mm * 60.0 + ss;
    return true;
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
    if (std::strcmp(type, "GGA") == 0) {
        // GGA: time, lat, N/S, lon, E/W, quality, sats, hdop, alt, M, geoid sep, M, …
        double quality = 0, alt = 0, sep = 0;
        if (n < 12 || !parseTimeOfDay(f[1], &r.timeOfDay_s) || !parseNumber(f[6], &quality)) {
            ++counters_.malformed;
            return false;
        }
        r.type = NmeaSentence::Type::Gga;
        r.valid = quality > 0;
        if (r.valid) {
            if (!parseLatLon(f[2], f[3], true, &r.lat_deg) ||
                !parseLatLon(f[4], f[5], false, &r.lon_deg) || !parseNumber(f[9], &alt)) {
                ++counters_.malformed;
                return false;
            }
            if (!parseNumber(f[11], &sep)) sep = 0.0;
            r.alt_m = alt + sep;
        }
    } else if (std::strcmp(type, "RMC") == 0) {
        // RMC: time, status, lat, N/S, lon, E/W, speed, course, date ddmmyy, …
        if (n < 10 || !parseTimeOfDay(f[1], &r.timeOfDay_s)) {
            ++counters_.malformed;
            return false;
        }
        r.type = NmeaSentence::Type::Rmc;
        r.valid = std::strcmp(f[2], "A") == 0;
        if (r.valid) {
            double date = 0;
            if (!parseLatLon(f[3], f[4], true, &r.lat_deg) ||
                !parseLatLon(f[5], f[6], false, &r.lon_deg) || std::strlen(f[9]) != 6 ||
                !parseNumber(f[9], &date)) {
                ++counters_.malformed;
                return false;
            }
            const int di = static_cast<int>(date);
            std::tm tm{};
            tm.tm_mday = di / 10000;
            tm.tm_mon = (di / 100) % 100 - 1;
            const int yy = di % 100;
            tm.tm_year = yy < 80 ? yy + 100 : yy;  // two-digit year: 1980–2079
            if (tm.tm_mday < 1 || tm.tm_mday > 31 || tm.tm_mon < 0 || tm.tm_mon > 11) {
                ++counters_.malformed;
                return false;
            }
            r.utc_unix_s = static_cast<double>(timegm(&tm)) + r.timeOfDay_s;
        }
    } else if (std::strcmp(type, "HDT") == 0) {
        if (n < 2 || !parseNumber(f[1], &r.heading_deg) || r.heading_deg < 0.0 ||
            r.heading_deg > 360.0) {
            ++counters_.malformed;
            return false;
        }
        r.type = NmeaSentence::Type::Hdt;
        r.valid = true;
    } else {
        ++counters_.unsupported;
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
