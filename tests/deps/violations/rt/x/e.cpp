#include <cstdlib>
const char* cache() {
    return std::getenv("NVS_CACHE_DIR");
}
