// Hidden-effect tests (DESIGN §9, docs/validation.md "diagnose"): a few seeds per catalog
// effect on small frames. Each dataset is generated with the effect at a random strength within
// its stated range and diagnosed with the model that lacks it; the top finding must name it and
// its parameters must come back within 20 %. A null dataset must give no finding; two hidden at
// once must both be named. `make validate` runs the same with 20 seeds and writes the table.
#include <gtest/gtest.h>

#include <cmath>

#include "sim/fit/diagnose.h"
#include "sim/fit/generate.h"

namespace nvs::fit {
namespace {

const std::filesystem::path kConfig = NVS_SOURCE_DIR "/config";
constexpr int kSeeds = 3;

Result run(const std::vector<std::string>& effects, int seed, Generated& g) {
    GenSpec s;
    s.effects = effects;
    s.seed = static_cast<std::uint64_t>(seed);
    g = generate(s, kConfig);
    return diagnose(g.data, kConfig);
}

std::string describe(const Result& r, const Generated& g) {
    std::string s = "truth:";
    for (const auto& [k, v] : g.truth)
        s += " " + k + "=" + std::to_string(v);
    s += "; findings:";
    for (const Finding& f : r.findings) {
        s += " [" + f.effect + " z=" + std::to_string(f.z);
        for (const auto& [k, v] : f.parameters)
            s += " " + k + "=" + std::to_string(v);
        s += "]";
    }
    return s;
}

// Every true parameter of `effect` that the finding reports, within 20 %.
void expectParameters(const Finding& f, const Generated& g, const std::string& why) {
    int checked = 0;
    for (const auto& [k, v] : g.truth) {
        if (k.rfind(f.effect + ".", 0) != 0) continue;
        for (const auto& [pk, pv] : f.parameters)
            if (f.effect + "." + pk == k) {
                EXPECT_NEAR(pv, v, 0.2 * std::fabs(v)) << k << "; " << why;
                ++checked;
            }
    }
    EXPECT_GT(checked, 0) << why;
}

class HiddenEffect : public ::testing::TestWithParam<const char*> {};

TEST_P(HiddenEffect, TopFindingNamesItAndRecoversItsParameters) {
    for (int seed = 1; seed <= kSeeds; ++seed) {
        Generated g;
        const Result r = run({GetParam()}, seed, g);
        const std::string why = "seed " + std::to_string(seed) + ": " + describe(r, g);
        ASSERT_FALSE(r.findings.empty()) << why;
        EXPECT_EQ(r.findings[0].effect, GetParam()) << why;
        if (r.findings[0].effect == GetParam()) expectParameters(r.findings[0], g, why);
    }
}

INSTANTIATE_TEST_SUITE_P(Catalog, HiddenEffect,
                         ::testing::Values("phosphor_persistence", "halo", "fixed_pattern_noise",
                                           "mcp_saturation", "bright_source_protection",
                                           "veiling_glare", "vertical_smear", "ebi_background",
                                           "excess_noise"));

TEST(HiddenEffectNull, NoFindingWithoutAnEffect) {
    for (int seed = 1; seed <= kSeeds; ++seed) {
        Generated g;
        const Result r = run({}, seed, g);
        EXPECT_TRUE(r.findings.empty()) << "seed " << seed << ": " << describe(r, g);
    }
}

TEST(HiddenEffectPair, BothEffectsAreNamed) {
    Generated g;
    const Result r = run({"vertical_smear", "excess_noise"}, 2, g);
    bool smear = false, noise = false;
    for (const Finding& f : r.findings) {
        smear = smear || f.effect == "vertical_smear";
        noise = noise || f.effect == "excess_noise";
    }
    EXPECT_TRUE(smear && noise) << describe(r, g);
}

}  // namespace
}  // namespace nvs::fit
