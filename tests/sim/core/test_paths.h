#pragma once
// Paths the tests read: the thesis data tables (tests/data/thesis) and the source tree.

#include <filesystem>

namespace nvs::test {

inline std::filesystem::path thesisData(const char* file) {
    return std::filesystem::path(NVS_TEST_DATA_DIR) / "thesis" / file;
}
inline std::filesystem::path sourceDir() {
    return NVS_SOURCE_DIR;
}

}  // namespace nvs::test
