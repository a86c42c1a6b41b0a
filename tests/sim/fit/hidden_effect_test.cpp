// Hidden-effect tests (docs/design.md §9, docs/validation.md "diagnose"): a few seeds per catalog
// effect on small frames. Each dataset is generated with the effect at a random strength within
// its stated range and diagnosed with the model that lacks it; in at least two of three seeds
// the top finding must name it with its parameters within 20 %. Null datasets must give no
// finding; two hidden at once must both be named. `make validate` runs the same with 20 seeds
// and writes the table (docs/validation.md, "diagnose").
#include <gtest/gtest.h>

#include <cmath>
#include <functional>

#include "sim/core/error.h"
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

// Whether every true parameter of the finding's effect that it reports is within 20 %.
bool parametersWithin20(const Finding& f, const Generated& g) {
    int checked = 0;
    for (const auto& [k, v] : g.truth) {
        if (k.rfind(f.effect + ".", 0) != 0) continue;
        for (const auto& [pk, pv] : f.parameters)
            if (f.effect + "." + pk == k) {
                if (std::fabs(pv - v) > 0.2 * std::fabs(v)) return false;
                ++checked;
            }
    }
    return checked > 0;
}

class HiddenEffect : public ::testing::TestWithParam<const char*> {};

// A regression check on three seeds: at least two must name the effect first with its
// parameters within 20 % (the 95 % rate over 20 seeds is make validate's, docs/validation.md).
TEST_P(HiddenEffect, TopFindingNamesItAndRecoversItsParameters) {
    int good = 0;
    std::string log;
    for (int seed = 1; seed <= kSeeds; ++seed) {
        Generated g;
        const Result r = run({GetParam()}, seed, g);
        const bool ok = !r.findings.empty() && r.findings[0].effect == GetParam() &&
                        parametersWithin20(r.findings[0], g);
        good += ok ? 1 : 0;
        log += "\nseed " + std::to_string(seed) + (ok ? " ok: " : " FAILED: ") + describe(r, g);
    }
    EXPECT_GE(good, kSeeds - 1) << log;
}

INSTANTIATE_TEST_SUITE_P(Catalog, HiddenEffect,
                         ::testing::Values("phosphor_persistence", "halo", "fixed_pattern_noise",
                                           "mcp_saturation", "bright_source_protection",
                                           "veiling_glare", "vertical_smear", "ebi_background",
                                           "excess_noise"));

// The excess noise fitted to a null dataset, whose camera is the model's: the measured temporal
// noise over the model's (variance_ratio_to_model, from the trial's record) must be 1 within
// its scatter. It was 1.04-1.16 on 19 of 20 null seeds (one 0.996) when the model's noise
// statistics were smoothed with weights from their own noisy values (docs/diagnose.md §2).
double nullVarianceRatio(const Result& r) {
    for (const Trial& t : r.trials) {
        const std::size_t at = t.why.find("variance_ratio_to_model = ");
        if (t.effect == "excess_noise" && at != std::string::npos)
            return std::stod(t.why.substr(at + 26));
    }
    return NAN;
}

TEST(HiddenEffectNull, NoFindingWithoutAnEffect) {
    double sum = 0.0;
    for (int seed = 1; seed <= kSeeds; ++seed) {
        Generated g;
        const Result r = run({}, seed, g);
        EXPECT_TRUE(r.findings.empty()) << "seed " << seed << ": " << describe(r, g);
        const double phi = nullVarianceRatio(r);
        EXPECT_NEAR(phi, 1.0, 0.04) << "seed " << seed;
        sum += phi;
    }
    EXPECT_NEAR(sum / kSeeds, 1.0, 0.025);
}

TEST(HiddenEffectNull, AnUnknownEffectNameIsASetupError) {
    GenSpec s;
    s.effects = {"none"};
    EXPECT_THROW(generate(s, kConfig), SetupError);
}

// --write-preset's round trip through the chain: the finding's preset keys as the model's
// settings (the chain implements these effects), diagnosed again, leave nothing to find.
TEST(HiddenEffectRoundTrip, TheFindingsKeysAsTheModelLeaveNothingToFind) {
    for (const char* effect : {"phosphor_persistence", "vertical_smear", "fixed_pattern_noise"}) {
        Generated g;
        const Result r = run({effect}, 2, g);
        ASSERT_FALSE(r.findings.empty()) << effect << ": " << describe(r, g);
        ASSERT_EQ(r.findings[0].effect, effect) << describe(r, g);
        Dataset d = g.data;
        for (const auto& [k, v] : r.findings[0].presetKeys)
            d.settings[k] = v;
        d.camera = loadModelCamera(kConfig, d.preset, d.settings, d.cameraExtra);
        const Result again = diagnose(d, kConfig);
        for (const Finding& f : again.findings)
            EXPECT_NE(f.effect, effect) << "again: " << describe(again, g);
    }
}

// Two hidden at once, as the single effects: in at least two of three seeds both are named.
TEST(HiddenEffectPair, BothEffectsAreNamed) {
    int good = 0;
    std::string log;
    for (int seed = 1; seed <= kSeeds; ++seed) {
        Generated g;
        const Result r = run({"vertical_smear", "excess_noise"}, seed, g);
        bool smear = false, noise = false;
        for (const Finding& f : r.findings) {
            smear = smear || f.effect == "vertical_smear";
            noise = noise || f.effect == "excess_noise";
        }
        good += smear && noise ? 1 : 0;
        log += "\nseed " + std::to_string(seed) + (smear && noise ? " ok: " : " FAILED: ") +
               describe(r, g);
    }
    EXPECT_GE(good, kSeeds - 1) << log;
}

// A halo with phosphor persistence: both named with their parameters within 20 % in at least
// two of three seeds. The chain spreads the halo over each field and the afterglow makes
// consecutive fields differ; spread over the assembled frame, the fraction came back 11-30 %
// low and the decay 7-33 % high on every seed (docs/validation.md, "diagnose").
// Two hidden effects, both named with their parameters within 20 %, in all seeds but one.
void expectPairRecovered(const char* a, const char* b) {
    int good = 0;
    std::string log;
    for (int seed = 1; seed <= kSeeds; ++seed) {
        Generated g;
        const Result r = run({a, b}, seed, g);
        int within = 0;
        for (const Finding& f : r.findings)
            if ((f.effect == a || f.effect == b) && parametersWithin20(f, g)) ++within;
        good += within == 2 ? 1 : 0;
        log += "\nseed " + std::to_string(seed) + (within == 2 ? " ok: " : " FAILED: ") +
               describe(r, g);
    }
    EXPECT_GE(good, kSeeds - 1) << log;
}

TEST(HiddenEffectPair, HaloWithPersistenceBothRecovered) {
    expectPairRecovered("halo", "phosphor_persistence");
}

// The halo spreads the light before the MCP saturates it (the chain's order): with the
// saturation applied first, the charge came back 14-29 % high on 4 of 6 seeds.
TEST(HiddenEffectPair, HaloWithSaturationBothRecovered) {
    expectPairRecovered("halo", "mcp_saturation");
}

// A registered effect of two parameters named first, and its law, a function of its two
// parameters at a few points, within `tol` of the truth's, in at least two of three seeds.
void expectRegisteredLaw(
    const std::string& name, const std::vector<double>& at, double tol,
    const std::function<double(double, double, double, const Generated&)>& law) {
    int good = 0;
    std::string log;
    for (int seed = 1; seed <= kSeeds; ++seed) {
        Generated g;
        const Result r = run({name}, seed, g);
        log += describe(r, g) + "\n";
        if (r.findings.empty() || r.findings[0].effect != name) continue;
        const Finding& f = r.findings[0];
        ASSERT_EQ(f.parameters.size(), 2u);
        const double t0 = g.truth.at(name + "." + f.parameters[0].first);
        const double t1 = g.truth.at(name + "." + f.parameters[1].first);
        bool close = true;
        for (double x : at)
            close = close && std::fabs(law(f.parameters[0].second, f.parameters[1].second, x, g) -
                                       law(t0, t1, x, g)) < tol;
        EXPECT_EQ(f.presetKeys.size(), 2u);
        good += close ? 1 : 0;
    }
    EXPECT_GE(good, 2) << log;
}

// An effect added through the registry (effect_registry.h, docs/diagnose.md "Adding an
// effect"): the frame grabber's line blur, hidden by the generator through the chain's own
// digitiser stage (sim/sensor/mtf.cpp), named first in at least two of three seeds. The law's
// two parameters trade against each other over the frequencies a frame holds (up to the
// Nyquist frequency at the cathode, 27.8 cycles/mm): what is checked is the law itself, the
// fitted MTF against the true one at a quarter, half and all of the Nyquist frequency, within
// 0.1 (seeds 1-3 after the joint refit: 0.02, 0.07 and 0.10 at the Nyquist frequency, where the
// true MTF is 0.08-0.39; the law's two parameters alone came back up to 27 % off).
TEST(HiddenRegistered, FrameGrabberBlurIsNamedWithItsLineMtf) {
    // x: the part of the Nyquist frequency at the cathode.
    expectRegisteredLaw("frame_grabber_blur", {0.25, 0.5, 1.0}, 0.1,
                        [](double fc, double index, double part, const Generated& g) {
                            const double pitch_mm =
                                g.data.camera.pitch_x_um * 1e-3 * g.data.camera.taper_magnification;
                            return std::exp(-std::pow(part * 0.5 / pitch_mm / fc, index));
                        });
}

// The second effect added through the registry: the AC-coupled video line's droop, hidden by
// the generator through the chain's video stage (video.streak_fraction, streak_tau_px;
// VideoStage::droopRow), named first in at least two of three seeds. The fraction and the
// time constant trade against each other where τ is long against the 128-pixel line; what is
// checked is the droop itself, 1 − f·(1 − exp(−x/τ)) of a flat line, fitted against true at
// 10, 40 and 120 px along it, within 0.01 (the true droop at 120 px is 3.5-20 %).
TEST(HiddenRegistered, VideoStreakIsNamedWithItsDroop) {
    // x: pixels along the line.
    expectRegisteredLaw("video_streak", {10.0, 40.0, 120.0}, 0.01,
                        [](double fraction, double tau, double x, const Generated&) {
                            return 1.0 - fraction * (1.0 - std::exp(-x / tau));
                        });
}

}  // namespace
}  // namespace nvs::fit
