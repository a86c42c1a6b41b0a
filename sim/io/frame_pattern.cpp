#include "sim/io/frame_pattern.h"

#include <cstdio>
#include <string_view>

namespace nvs::io {

bool hasFramePattern(const std::string& pattern) {
    return pattern.find("{frame") != std::string::npos;
}

std::string expandFramePattern(const std::string& pattern, long long frame) {
    // "{frame}" or "{frame:Nd}" / "{frame:0Nd}" with N of at most two digits (width ≤ 20, the
    // digits of a 64-bit number): the first well-formed field is expanded, the rest of the
    // name kept as is. Scanned by hand: no regex, no std::stoi to throw on a long number.
    constexpr std::string_view kOpen = "{frame";
    for (std::size_t at = pattern.find(kOpen); at != std::string::npos;
         at = pattern.find(kOpen, at + 1)) {
        std::size_t i = at + kOpen.size();
        int width = 0;
        if (i < pattern.size() && pattern[i] == ':') {
            ++i;
            if (i < pattern.size() && pattern[i] == '0') ++i;
            const std::size_t digits = i;
            while (i < pattern.size() && i - digits < 3 && pattern[i] >= '0' && pattern[i] <= '9')
                width = width * 10 + (pattern[i++] - '0');
            if (i == digits || i - digits > 2 || i >= pattern.size() || pattern[i] != 'd') continue;
            ++i;
        }
        if (i >= pattern.size() || pattern[i] != '}' || width > 20) continue;
        char buf[32];
        std::snprintf(buf, sizeof buf, "%0*lld", width, frame);
        return pattern.substr(0, at) + buf + pattern.substr(i + 1);
    }
    return pattern;
}

}  // namespace nvs::io
