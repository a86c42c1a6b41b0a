#pragma once
// The Embree kernel set the render tests run with: NVS_EMBREE_ISA read by the runtime's one
// reader of the environment (rt/compose/environment.h), so that ctest's isa.native.* entries
// run these tests on each set of kernels (tests/isa).

#include "rt/compose/environment.h"

namespace nvs::render {

using rt::embreeIsaPin;

}  // namespace nvs::render
