#include "sim/fit/text.h"

#include <cstdarg>
#include <cstdio>

namespace nvs::fit {

std::string textf(const char* format, ...) {
    char b[512];
    va_list a;
    va_start(a, format);
    std::vsnprintf(b, sizeof b, format, a);
    va_end(a);
    return b;
}

std::string jsonString(const std::string& text) {
    std::string s = "\"";
    for (char c : text) {
        if (static_cast<unsigned char>(c) < 0x20)
            s += textf("\\u%04x", static_cast<unsigned>(c));
        else
            s += c == '"' || c == '\\' ? std::string("\\") + c : std::string(1, c);
    }
    return s + "\"";
}

}  // namespace nvs::fit
