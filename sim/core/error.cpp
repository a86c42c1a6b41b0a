#include "sim/core/error.h"

namespace nvs {

std::string FileLoc::str() const {
    std::string s = file.empty() ? std::string("<input>") : file;
    if (line > 0) {
        s += ":" + std::to_string(line);
        if (column > 0) s += ":" + std::to_string(column);
    }
    return s;
}

SetupError::SetupError(const FileLoc& loc, const std::string& message)
    : std::runtime_error(loc.str() + ": " + message) {}

}  // namespace nvs
