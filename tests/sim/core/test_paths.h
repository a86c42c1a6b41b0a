#pragma once
// Paths the tests read: the thesis data tables (tests/data/thesis), the source tree, and the
// data folders the tests hand to sim/ (the source tree's config/, the build tree's cache/: the
// same folders ctest gives the `nvstim` runs through NVS_CONFIG_DIR and NVS_CACHE_DIR).

#include <filesystem>

#include "sim/core/paths.h"

namespace nvs::test {

inline std::filesystem::path thesisData(const char* file) {
    return std::filesystem::path(NVS_TEST_DATA_DIR) / "thesis" / file;
}
inline std::filesystem::path sourceDir() {
    return NVS_SOURCE_DIR;
}
inline std::filesystem::path configDir() {
    return sourceDir() / "config";
}
inline DataDirs dataDirs() {
    return DataDirs{configDir(), std::filesystem::path(NVS_BINARY_DIR) / "cache"};
}

}  // namespace nvs::test
