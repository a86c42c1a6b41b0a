#pragma once
// The Embree kernel set the render tests run with: NVS_EMBREE_ISA as the runtime reads it
// (rt/compose renderConfigFor), so that ctest's isa.native.* entries run these tests on each
// set of kernels (tests/isa).

#include <cstdlib>
#include <string>

#include "sim/core/cpu_isa.h"

namespace nvs::render {

inline std::string embreeIsaPin() {
    const char* v = std::getenv(kEmbreeIsaEnv);
    return v == nullptr ? std::string() : std::string(v);
}

}  // namespace nvs::render
