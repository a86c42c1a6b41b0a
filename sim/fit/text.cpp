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

}  // namespace nvs::fit
