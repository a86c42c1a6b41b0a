#pragma once
// What the sim/fit tests share: the shipped configuration, a clean folder per test, a small
// generated dataset.
#include <gtest/gtest.h>

#include <filesystem>
#include <functional>
#include <string>
#include <utility>
#include <vector>

#include "sim/core/error.h"
#include "sim/fit/dataset.h"
#include "sim/fit/generate.h"

namespace nvs::fit::test {

inline const std::filesystem::path kConfig = NVS_SOURCE_DIR "/config";

// BINARY_DIR/test-fit/NAME, empty.
inline std::filesystem::path tempDir(const std::string& name) {
    const std::filesystem::path p = std::filesystem::path(NVS_BINARY_DIR) / "test-fit" / name;
    std::filesystem::remove_all(p);
    std::filesystem::create_directories(p);
    return p;
}

// A 48 x 32 dataset: 3 stimuli held for 4 frames each (12 frames).
inline Generated small(std::vector<std::string> effects = {}) {
    GenSpec s;
    s.effects = std::move(effects);
    s.width = 48;
    s.height = 32;
    s.stimuli = 3;
    s.hold = 4;
    return generate(s, kConfig);
}

// A dataset spoiled one way, and what its one-line SetupError must name.
struct SpoilCase {
    const char* what;
    std::function<void(const std::filesystem::path&)> spoil;
    const char* named;
};

// Each case on a fresh copy of `data` in tempDir(folder): loadDataset throws one SetupError of
// one line naming what it should, and nothing else.
inline void expectEachSetupError(const Dataset& data, const std::vector<SpoilCase>& cases,
                                 const std::string& folder) {
    for (const SpoilCase& c : cases) {
        const std::filesystem::path dir = tempDir(folder);
        writeDataset(data, dir);
        c.spoil(dir);
        try {
            (void)loadDataset(dir, kConfig);
            ADD_FAILURE() << c.what << ": no error";
        } catch (const SetupError& e) {
            const std::string m = e.what();
            EXPECT_NE(m.find(c.named), std::string::npos) << c.what << ": " << m;
            EXPECT_EQ(m.find('\n'), std::string::npos) << c.what << ": " << m;
        } catch (const std::exception& e) {
            ADD_FAILURE() << c.what << ": not a SetupError: " << e.what();
        }
    }
    std::filesystem::remove_all(tempDir(folder));
}

}  // namespace nvs::fit::test
