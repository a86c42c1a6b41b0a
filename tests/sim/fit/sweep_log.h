#pragma once
// What the two hidden-effect sweep tools (nvs_validate_diagnose, nvs_validate_scene) share: the
// per-seed line (`-v`: the hidden truth, then each finding with its z and parameters, on
// stderr), the --size parser and their main().

#include <cstdio>
#include <map>
#include <string>

#include "sim/core/error.h"
#include "sim/fit/diagnose.h"

namespace nvs::fit::test {

inline void logSeed(const std::string& hidden, int seed, const std::map<std::string, double>& truth,
                    const Result& r) {
    std::fprintf(stderr, "%s seed %d:", hidden.c_str(), seed);
    for (const auto& [k, v] : truth)
        std::fprintf(stderr, " %s=%.4g", k.c_str(), v);
    std::fprintf(stderr, " ->");
    for (const auto& f : r.findings) {
        std::fprintf(stderr, " [%s%s%s z=%.1f", f.effect.c_str(),
                     f.effect == "unexplained" ? (":" + f.structure).c_str() : "",
                     f.status == "candidate" ? " (candidate)" : "", f.z);
        for (const auto& [k, v] : f.parameters)
            std::fprintf(stderr, " %s=%.4g", k.c_str(), v);
        std::fprintf(stderr, "]");
    }
    std::fprintf(stderr, "\n");
}

// "WxH", each at least 16; anything else is a setup error naming the option.
inline void parseFrameSize(const std::string& text, int& w, int& h) {
    char tail = 0;
    if (std::sscanf(text.c_str(), "%dx%d%c", &w, &h, &tail) != 2 || w < 16 || h < 16)
        throw SetupError("--size: expected WxH, at least 16x16, got '" + text + "'");
}

// A sweep tool's main(): run(argc, argv), a setup error (bad input) as one line, exit status 2.
inline int mainOf(const char* tool, int (*run)(int, char**), int argc, char** argv) {
    try {
        return run(argc, argv);
    } catch (const SetupError& e) {
        std::fprintf(stderr, "%s: %s\n", tool, e.what());
        return 2;
    }
}

}  // namespace nvs::fit::test
