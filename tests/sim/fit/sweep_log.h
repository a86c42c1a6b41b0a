#pragma once
// The per-seed line of the hidden-effect sweeps (`-v`): the hidden truth, then each finding with
// its z and parameters, on stderr.

#include <cstdio>
#include <map>
#include <string>

#include "sim/fit/diagnose.h"

namespace nvs::fit::test {

inline void logSeed(const std::string& hidden, int seed, const std::map<std::string, double>& truth,
                    const Result& r) {
    std::fprintf(stderr, "%s seed %d:", hidden.c_str(), seed);
    for (const auto& [k, v] : truth)
        std::fprintf(stderr, " %s=%.4g", k.c_str(), v);
    std::fprintf(stderr, " ->");
    for (const auto& f : r.findings) {
        std::fprintf(stderr, " [%s z=%.1f", f.effect.c_str(), f.z);
        for (const auto& [k, v] : f.parameters)
            std::fprintf(stderr, " %s=%.4g", k.c_str(), v);
        std::fprintf(stderr, "]");
    }
    std::fprintf(stderr, "\n");
}

}  // namespace nvs::fit::test
