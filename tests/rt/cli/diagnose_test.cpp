// nvstim diagnose as a user meets it (docs/contracts.md "diagnose"): a generated dataset with a
// hidden halo is diagnosed, the JSON names it, the report has its plots, and the preset written
// by --write-preset, used again, leaves nothing to find; bad datasets exit 2 with one line and
// write nothing.
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include "rt/cli/cli.h"
#include "sim/fit/compare.h"
#include "sim/fit/dataset.h"
#include "sim/fit/effect_registry.h"
#include "sim/fit/generate.h"
#include "tests/rt/cli/cli_run.h"

namespace nvs {
namespace {

namespace fs = std::filesystem;

using test::CliRun;
using test::nvstim;
using test::WorkDir;

fs::path writeHalo(const fs::path& dir) {
    fit::GenSpec s;
    s.effects = {"halo"};
    s.seed = 1;
    fit::writeDataset(fit::generate(s, NVS_SOURCE_DIR "/config").data, dir / "halo");
    return dir / "halo";
}

TEST(Diagnose, NamesAHiddenHaloAndItsPresetLeavesNothingToFind) {
    const WorkDir work;
    const fs::path& dir = work.path;
    const fs::path ds = writeHalo(dir);
    // Links where the temporaries used to go (OUT.tmp) are neither followed nor replaced.
    std::ofstream(dir / "victim.txt") << "keep me";
    fs::create_symlink(dir / "victim.txt", dir / "out.json.tmp");
    fs::create_symlink(dir / "victim.txt", dir / "fitted.toml.tmp");
    const CliRun r = nvstim("diagnose " + ds.string() + " --json " + (dir / "out.json").string() +
                            " --write-preset " + (dir / "fitted.toml").string());
    ASSERT_EQ(r.status, 0) << r.err;
    {
        std::ifstream v(dir / "victim.txt");
        EXPECT_EQ(std::string(std::istreambuf_iterator<char>(v), {}), "keep me");
    }
    EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(dir / "out.json")));
    EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(dir / "fitted.toml")));
    for (const auto& e : fs::directory_iterator(dir))
        EXPECT_EQ(e.path().string().find(".nvstim-"), std::string::npos) << e.path();
    EXPECT_NE(r.out.find("{\"baseline\":{"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find("\"findings\":[{\"effect\":\"halo\""), std::string::npos) << r.out;
    for (const char* key : {"\"parameters\"", "\"heldout_rms_before\"", "\"heldout_rms_after\"",
                            "\"confidence\"", "\"radius_um\"", "\"fraction\""})
        EXPECT_NE(r.out.find(key), std::string::npos) << key;
    EXPECT_NE(r.err.find("nvstim diagnose:"), std::string::npos) << "progress on stderr";
    // Each round's progress lines count its effects: "(k/N)", k = 1 … N in order, the same N.
    {
        const std::regex line(R"(\] (structure )?round (\d+): \w+ \((\d+)/(\d+)\))");
        std::istringstream lines(r.err);
        std::string l, lastRound;
        long expectK = 1, n = 0, rounds = 0;
        for (std::smatch m; std::getline(lines, l);) {
            if (!std::regex_search(l, m, line)) continue;
            const std::string round = m[1].str() + m[2].str();
            if (round != lastRound) {
                EXPECT_TRUE(lastRound.empty() || expectK == n + 1) << "round " << lastRound;
                lastRound = round;
                expectK = 1;
                n = std::stol(m[4]);
                ++rounds;
            }
            EXPECT_EQ(std::stol(m[3]), expectK++) << l;
            EXPECT_EQ(std::stol(m[4]), n) << l;
        }
        EXPECT_EQ(expectK, n + 1) << "the last round ends at N";
        EXPECT_GE(rounds, 2) << r.err;
    }
    std::ifstream json(dir / "out.json");
    std::string line;
    std::getline(json, line);
    EXPECT_EQ(line + "\n", r.out);
    // The fitted preset, used as the model, has the halo: nothing left to find.
    fs::copy_file(dir / "fitted.toml", ds / "fitted.toml");
    std::ifstream in(ds / "dataset.toml");
    std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    text.replace(text.find("preset = \"pulnix-ag5745ef3\""), 27, "preset = \"fitted.toml\"");
    // The generated dataset's settings switch the chain's halo off (the model without it); the
    // fitted preset switches it on: that setting goes.
    const std::size_t off = text.find("\"halo.enabled\" = false\n");
    ASSERT_NE(off, std::string::npos) << text;
    text.erase(off, std::string("\"halo.enabled\" = false\n").size());
    std::ofstream(ds / "dataset.toml") << text;
    const CliRun again = nvstim("diagnose " + ds.string());
    ASSERT_EQ(again.status, 0) << again.err;
    EXPECT_NE(again.out.find("\"findings\":[]"), std::string::npos) << again.out;
}

TEST(Diagnose, ReportHasItsPlots) {
    if (!fs::exists("/usr/bin/python3") ||
        std::system("/usr/bin/python3 -c 'import matplotlib' 2>/dev/null") != 0)
        GTEST_SKIP() << "python3-matplotlib is not installed (make test installs it)";
    const WorkDir work;
    const fs::path& dir = work.path;
    const fs::path ds = writeHalo(dir);
    // A folder of the user's where the temporary report used to go stays as it is.
    fs::create_directories(dir / "report.tmp");
    std::ofstream(dir / "report.tmp" / "sentinel.txt") << "keep me";
    const CliRun r = nvstim("diagnose " + ds.string() + " --report " + (dir / "report").string());
    ASSERT_EQ(r.status, 0) << r.err;
    for (const char* f :
         {"report.md", "photon_transfer.png", "linearity.png", "radial_profile.png",
          "residual_heldout_before.png", "residual_heldout_after.png", ".nvstim-diagnose-report"})
        EXPECT_TRUE(fs::exists(dir / "report" / f)) << f;
    EXPECT_TRUE(fs::exists(dir / "report.tmp" / "sentinel.txt"));
    for (const auto& e : fs::directory_iterator(dir))
        EXPECT_EQ(e.path().string().find(".nvstim-"), std::string::npos) << e.path();
}

TEST(Diagnose, BadDatasetExitsTwoWithOneLineAndWritesNothing) {
    const WorkDir work;
    const fs::path& dir = work.path;
    const fs::path ds = writeHalo(dir);
    std::ifstream in(ds / "dataset.toml");
    const std::string good((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    struct Case {
        std::string from, to, named;
    };
    for (const Case& c : {Case{"preset = \"pulnix-ag5745ef3\"", "preset = \"no-such\"", "no-such"},
                          Case{"unit = \"pe/s/m2/sr\"", "unit = \"lux\"", "'lux'"},
                          Case{"count = 48", "count = 49", "frame 48 is missing"},
                          Case{"count = 48", "count = 6", "'output.count': must be in [8,"}}) {
        std::string t = good;
        t.replace(t.find(c.from), c.from.size(), c.to);
        std::ofstream(ds / "dataset.toml") << t;
        const fs::path out = dir / "out.json", preset = dir / "p.toml", rep = dir / "rep";
        const CliRun r = nvstim("diagnose " + ds.string() + " --json " + out.string() +
                                " --write-preset " + preset.string() + " --report " + rep.string());
        EXPECT_EQ(r.status, cli::kExitUsage) << c.to;
        EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << r.err;
        EXPECT_NE(r.err.find(c.named), std::string::npos) << r.err;
        EXPECT_TRUE(r.out.empty());
        EXPECT_FALSE(fs::exists(out) || fs::exists(preset) || fs::exists(rep)) << c.to;
    }
}

// The gain of a fix, measured on held-out frames: the model with the hidden halo's true
// parameters (the generator's truth, not a fit) against the model without it. The true model
// must predict better (z > 5), most where the halo carries light (the bright level third), and a
// model against itself must show no gain at all.
TEST(Diagnose, CompareShowsTheGainOfTheTrueHaloModel) {
    fit::GenSpec s;
    s.effects = {"halo"};
    s.seed = 1;
    const fit::Generated g = fit::generate(s, NVS_SOURCE_DIR "/config");
    sensor::Overrides truth = g.data.settings;
    truth["halo.enabled"] = "true";
    truth["halo.fraction"] = std::to_string(g.truth.at("halo.fraction"));
    truth["halo.radius_um"] = std::to_string(g.truth.at("halo.radius_um"));
    const fit::Comparison c = fit::compareModels(
        g.data, NVS_SOURCE_DIR "/config", "pulnix-ag5745ef3", "pulnix-ag5745ef3", {}, {}, &truth);
    EXPECT_GT(c.z, 5.0);
    EXPECT_LT(c.b.heldoutRms_dc, c.a.heldoutRms_dc);
    EXPECT_GT(c.b.logLikelihoodPerPixel, c.a.logLikelihoodPerPixel);
    ASSERT_EQ(c.regions.size(), 12u);
    EXPECT_EQ(c.regions[11], "level: bright third");
    EXPECT_GT(c.regionGain_pct[11], c.regionGain_pct[9]) << "bright third against dark third";
    const fit::Comparison same = fit::compareModels(g.data, NVS_SOURCE_DIR "/config",
                                                    "pulnix-ag5745ef3", "pulnix-ag5745ef3");
    EXPECT_EQ(same.z, 0.0);
    EXPECT_EQ(same.a.heldoutRms_dc, same.b.heldoutRms_dc);
}

// The gain of each effect added through the registry (effect_registry.h), measured as a user
// measures a fix: on a dataset with the effect hidden, the model with the effect's true
// parameters (its preset keys from the generator's truth) against the model without it.
TEST(Diagnose, CompareShowsTheGainOfEachRegisteredEffect) {
    for (const fit::RegisteredEffect* e : fit::registeredEffects()) {
        fit::GenSpec s;
        s.effects = {e->name};
        s.seed = 1;
        const fit::Generated g = fit::generate(s, NVS_SOURCE_DIR "/config");
        std::vector<double> p;
        for (const fit::EffectParameter& ep : e->parameters)
            p.push_back(g.truth.at(std::string(e->name) + "." + ep.name));
        sensor::Overrides truth = g.data.settings;
        for (const auto& [key, value] : fit::registeredPresetKeys(*e, p))
            truth[key] = value;
        const fit::Comparison c =
            fit::compareModels(g.data, NVS_SOURCE_DIR "/config", g.data.camera.name,
                               g.data.camera.name, {}, {}, &truth);
        EXPECT_GT(c.z, 5.0) << e->name;
        EXPECT_LT(c.b.heldoutRms_dc, c.a.heldoutRms_dc) << e->name;
        EXPECT_GT(c.b.logLikelihoodPerPixel, c.a.logLikelihoodPerPixel) << e->name;
        std::printf("%s: held-out RMS %.3f -> %.3f DC, z %.1f\n", e->name, c.a.heldoutRms_dc,
                    c.b.heldoutRms_dc, c.z);
    }
}

// The command line: --compare prints the comparison, --report draws it, and --compare with
// --write-preset is refused (there is nothing to write).
TEST(Diagnose, CompareOnTheCommandLine) {
    const WorkDir work;
    const fs::path ds = writeHalo(work.path);
    const CliRun r =
        nvstim("diagnose " + ds.string() + " --compare pulnix-ag5745ef3 pulnix-ag5745ef3 --json " +
               (work.path / "c.json").string());
    ASSERT_EQ(r.status, 0) << r.err;
    for (const char* key : {"{\"compare\":{\"a\":{\"preset\":\"pulnix-ag5745ef3\"",
                            "\"heldout_rms_dc\"", "\"log_likelihood_per_pixel\"",
                            "\"regions\":[{\"name\":\"top left\"", "\"gain_pct\"", "\"z\":0"})
        EXPECT_NE(r.out.find(key), std::string::npos) << key << " in " << r.out;
    EXPECT_TRUE(fs::exists(work.path / "c.json"));
    const CliRun bad = nvstim("diagnose " + ds.string() +
                              " --compare pulnix-ag5745ef3 pulnix-ag5745ef3 --write-preset " +
                              (work.path / "p.toml").string());
    EXPECT_EQ(bad.status, 2) << bad.err;
    EXPECT_FALSE(fs::exists(work.path / "p.toml"));
    const CliRun missing =
        nvstim("diagnose " + ds.string() + " --compare pulnix-ag5745ef3 no-such-preset");
    EXPECT_EQ(missing.status, 2) << missing.err;
}

}  // namespace
}  // namespace nvs
