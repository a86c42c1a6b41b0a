#pragma once
// Shared set-up of the sim/lwir tests: the coefficients from the source tree's config/.

#include "sim/lwir/absorption.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::lwir::test {

inline const AbsorptionData& data() {
    static const AbsorptionData d = AbsorptionData::load(nvs::test::configDir());
    return d;
}

}  // namespace nvs::lwir::test
