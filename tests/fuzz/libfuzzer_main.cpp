// libFuzzer's entry point for one target, chosen at compile time (tests/fuzz/CMakeLists.txt
// defines NVS_FUZZ_ENTRY as one of the functions of fuzz_targets.h).
#include "tests/fuzz/fuzz_targets.h"

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
    return NVS_FUZZ_ENTRY(data, size);
}
