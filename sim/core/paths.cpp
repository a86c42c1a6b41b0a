#include "sim/core/paths.h"

#include <cstdlib>

namespace nvs {

std::filesystem::path configDir() {
    if (const char* env = std::getenv("NVS_CONFIG_DIR"); env != nullptr && *env != '\0') {
        return env;
    }
    return NVS_DEFAULT_CONFIG_DIR;
}

}  // namespace nvs
