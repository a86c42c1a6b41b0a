#pragma once
// The message of the SetupError a call throws, or "" when it throws none (for tests that check
// what a bad input's error names).

#include <functional>
#include <string>

#include "sim/core/error.h"

namespace nvs::test {

inline std::string setupErrorOf(const std::function<void()>& f) {
    try {
        f();
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

}  // namespace nvs::test
