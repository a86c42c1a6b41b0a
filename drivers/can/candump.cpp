#include <cstdio>
#include <cstdlib>

#include "drivers/can/can.h"

namespace nvs::drivers {

namespace {

int hexValue(char c) {
    if (c >= '0' && c <= '9') return c - '0';
    if (c >= 'a' && c <= 'f') return c - 'a' + 10;
    if (c >= 'A' && c <= 'F') return c - 'A' + 10;
    return -1;
}

// "seconds.fraction" as candump writes it ("%ld.%06ld"): 1..kMaxSecondDigits digits, a point,
// 1..9 digits. Bounded so that every accepted time converts to an integer count of seconds
// without overflow (formatCandumpLine) and a garbage number of digits is refused.
constexpr std::size_t kMaxSecondDigits = 11;  // < 10^11 s, about 3170 years

bool parseCandumpTime(std::string_view s, double* t_s) {
    const std::size_t dot = s.find('.');
    if (dot == std::string_view::npos || dot == 0 || dot > kMaxSecondDigits ||
        s.size() - dot - 1 < 1 || s.size() - dot - 1 > 9) {
        return false;
    }
    char num[kMaxSecondDigits + 11];
    for (std::size_t k = 0; k < s.size(); ++k) {
        if (k != dot && (s[k] < '0' || s[k] > '9')) return false;
        num[k] = s[k];
    }
    num[s.size()] = '\0';
    // strtod of the checked digits: the nearest double, as candump logs were always read.
    *t_s = std::strtod(num, nullptr);
    return true;
}

}  // namespace

bool parseCandumpLine(std::string_view line, double* t_s, CanFrame* frame) noexcept {
    // "(" seconds "." micro ")" space iface space id "#" data
    std::size_t i = 0;
    while (i < line.size() && line[i] == ' ')
        ++i;
    if (i >= line.size() || line[i] != '(') return false;
    const std::size_t close = line.find(')', i);
    if (close == std::string_view::npos) return false;
    double t = 0.0;
    if (!parseCandumpTime(line.substr(i + 1, close - i - 1), &t)) return false;
    std::size_t p = close + 1;
    if (p >= line.size() || line[p] != ' ') return false;
    ++p;
    const std::size_t sp = line.find(' ', p);
    if (sp == std::string_view::npos || sp == p) return false;  // interface name
    p = sp + 1;
    const std::size_t hash = line.find('#', p);
    if (hash == std::string_view::npos) return false;
    const std::size_t idDigits = hash - p;
    if (idDigits != 3 && idDigits != 8) return false;
    std::uint32_t id = 0;
    for (std::size_t k = p; k < hash; ++k) {
        const int h = hexValue(line[k]);
        if (h < 0) return false;
        id = (id << 4) | static_cast<std::uint32_t>(h);
    }
    CanFrame f;
    f.extended = idDigits == 8;
    if ((!f.extended && id > 0x7FF) || id > 0x1FFFFFFF) return false;
    f.id = id;
    std::size_t d = hash + 1;
    if (d < line.size() && line[d] == '#') {
        f.fd = true;
        ++d;
        if (d >= line.size()) return false;
        const int fl = hexValue(line[d]);
        if (fl < 0) return false;
        f.flags = static_cast<std::uint8_t>(fl);
        ++d;
    } else if (d < line.size() && line[d] == 'R') {
        f.rtr = true;
        ++d;
        // optional DLC digit after R
        if (d < line.size() && hexValue(line[d]) >= 0) ++d;
        std::size_t e = d;
        while (e < line.size() && (line[e] == ' ' || line[e] == '\r' || line[e] == '\n'))
            ++e;
        if (e != line.size()) return false;
        *frame = f;
        *t_s = t;
        return true;
    }
    std::size_t e = line.size();
    while (e > d && (line[e - 1] == '\r' || line[e - 1] == '\n' || line[e - 1] == ' '))
        --e;
    const std::size_t hexLen = e - d;
    if (hexLen % 2 != 0) return false;
    const std::size_t bytes = hexLen / 2;
    if (bytes > (f.fd ? 64u : 8u)) return false;
    for (std::size_t k = 0; k < bytes; ++k) {
        const int hi = hexValue(line[d + 2 * k]);
        const int lo = hexValue(line[d + 2 * k + 1]);
        if (hi < 0 || lo < 0) return false;
        f.data[k] = static_cast<std::uint8_t>(hi * 16 + lo);
    }
    f.len = static_cast<std::uint8_t>(bytes);
    *frame = f;
    *t_s = t;
    return true;
}

std::size_t formatCandumpLine(double t_s, const char* iface, const CanFrame& frame, char* buf,
                              std::size_t size) noexcept {
    // The same range parseCandumpLine accepts; outside it the conversion below would overflow.
    if (!(t_s >= 0.0 && t_s < kMaxCandumpTime_s) || size == 0) return 0;
    const long long sec = static_cast<long long>(t_s);
    long long usec = static_cast<long long>((t_s - static_cast<double>(sec)) * 1e6 + 0.5);
    long long s = sec;
    if (usec >= 1000000) {
        ++s;
        usec -= 1000000;
    }
    int n = std::snprintf(buf, size,
                          frame.extended ? "(%lld.%06lld) %s %08X#" : "(%lld.%06lld) %s %03X#", s,
                          usec, iface, frame.id);
    if (n < 0 || static_cast<std::size_t>(n) >= size) return 0;
    std::size_t len = static_cast<std::size_t>(n);
    static const char kHex[] = "0123456789ABCDEF";
    if (frame.rtr) {
        if (len + 2 >= size) return 0;
        buf[len++] = 'R';
    } else {
        if (frame.fd) {
            if (len + 2 >= size) return 0;
            buf[len++] = '#';
            buf[len++] = kHex[frame.flags & 0xF];
        }
        if (len + 2u * frame.len + 2 >= size) return 0;
        for (int k = 0; k < frame.len; ++k) {
            buf[len++] = kHex[frame.data[k] >> 4];
            buf[len++] = kHex[frame.data[k] & 0xF];
        }
    }
    buf[len++] = '\n';
    buf[len] = '\0';
    return len;
}

}  // namespace nvs::drivers
