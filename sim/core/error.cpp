#include "sim/core/error.h"

namespace nvs {

std::string FileLoc::str() const {
    std::string s = file.empty() ? std::string("<input>") : file;
    // Appended piecewise rather than as `":" + std::to_string(n)`: GCC 12 at -O3 inlines that
    // operator+ into a memcpy it cannot prove non-overlapping and reports a false
    // -Wrestrict (GCC bug 105329), which fails a -Werror build.
    if (line > 0) {
        s += ':';
        s += std::to_string(line);
        if (column > 0) {
            s += ':';
            s += std::to_string(column);
        }
    }
    return s;
}

SetupError::SetupError(const FileLoc& loc, const std::string& message)
    : std::runtime_error(loc.str() + ": " + message) {}

}  // namespace nvs
