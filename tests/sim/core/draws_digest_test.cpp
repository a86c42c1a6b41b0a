// The per-pixel samplers give the same bits on every target: a digest of a fixed set of draws
// (Philox words, Poisson rows across the inversion's and PTRS's ranges, normals, tabulated Gamma
// draws) is checked against tests/sim/core/draws_digest.txt by the main test build (which picks
// the AVX-512, AVX2 or baseline versions at run time) and by the single-target builds. An
// intended change to a sampler changes the digest: the test prints the new one to store.

#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <string>
#include <vector>

#include "sim/core/fnv.h"
#include "sim/core/gamma_table.h"
#include "sim/core/rng.h"

namespace nvs {
namespace {

TEST(Draws, SameBitsOnEveryTarget) {
    const int w = 777;  // not a whole number of vectors
    Fnv1a d;
    std::vector<std::uint32_t> words(static_cast<std::size_t>(w + 3));
    std::vector<float> mean(static_cast<std::size_t>(w)), out(static_cast<std::size_t>(w));
    const PixelRng rng(0x5eed, RngStream::Photocathode, 12345);
    for (int y = 0; y < 64; ++y) {
        const auto yy = static_cast<std::uint32_t>(y);
        rng.rowWords(yy, 0, 0, (w + 3) / 4, words.data());
        d.bytes(words.data(), words.size() * sizeof(std::uint32_t));
        // Means from 1e-4 to 1e3 on a log scale, shuffled differently on each row; some rows
        // dense (most pixels open), some sparse.
        const double top = y % 3 == 0 ? -1.0 : (y % 3 == 1 ? 1.0 : 3.0);
        for (int x = 0; x < w; ++x)
            mean[static_cast<std::size_t>(x)] = static_cast<float>(
                std::pow(10.0, top - (top + 4.0) * ((x * 7919 + y * 104729) % w) / w));
        poissonRow(mean.data(), words.data(), out.data(), w, rng, 0, yy);
        d.bytes(out.data(), out.size() * sizeof(float));
        normalsFromWords(words.data(), out.data(), w);
        d.bytes(out.data(), out.size() * sizeof(float));
    }
    GammaTableCache tables;
    const auto table = tables.forShapeStep(1.0 / 0.6);
    for (int y = 0; y < 16; ++y) {
        PixelRng(0x5eed, RngStream::McpGain, 7)
            .rowWords(static_cast<std::uint32_t>(y), 0, 0, (w + 3) / 4, words.data());
        for (int x = 0; x < w; ++x)
            mean[static_cast<std::size_t>(x)] = static_cast<float>((x * 31 + y) % 40);
        gammaTableDraws(*table, mean.data(), words.data(), out.data(), w, 4321.0f);
        d.bytes(out.data(), out.size() * sizeof(float));
    }
    char hex[17];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(d.h));
    std::ifstream f(std::string(NVS_SOURCE_DIR) + "/tests/sim/core/draws_digest.txt");
    std::string expected;
    f >> expected;
    EXPECT_EQ(expected, hex) << "draws digest changed; if the samplers were meant to change, store "
                             << hex << " in tests/sim/core/draws_digest.txt";
}

}  // namespace
}  // namespace nvs
