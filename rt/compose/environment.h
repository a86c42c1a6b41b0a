#pragma once
// The process environment, read here and nowhere else (sim/ may not read it at all:
// cmake/CheckDependencies.cmake). The variables nvstim reads, and who asks:
//   NVS_EMBREE_ISA   Embree's kernel set, pinned lower than the CPU's for tests of each set
//                    (embreeIsaPin: the render set-up, replay's fingerprint; docs/portability.md)
//   NVS_CONFIG_DIR, NVS_CACHE_DIR, XDG_CACHE_HOME, HOME   the data and cache folders
//                    (rt/cli/data_dirs.cpp; docs/contracts.md, "Environment")
// Header-only, so that a test program reads the pin exactly as the runtime does without
// linking the runtime.

#include <cstdlib>
#include <string>

#include "sim/core/cpu_isa.h"

namespace nvs::rt {

// The value of an environment variable, or nullptr where it is not set.
inline const char* environmentValue(const char* name) noexcept {
    return std::getenv(name);
}

// NVS_EMBREE_ISA as given ("" where unset); validated where it is used (embreeDeviceConfig).
inline std::string embreeIsaPin() {
    const char* v = environmentValue(kEmbreeIsaEnv);
    return v == nullptr ? std::string() : std::string(v);
}

}  // namespace nvs::rt
