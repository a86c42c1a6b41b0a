// The hidden scenario-effect sweep behind `make validate` (docs/validation.md, "Scenario
// effects"): for lunar_sky_scatter, refraction, cloud_transmission, aerosol_extinction and the
// null case, N seeds of datasets rendered from the RIT roof in each effect's setup
// (sim/fit/generate_scene.h: the setting Moon; its disk in view for refraction; a full-Moon night
// for the cloud), diagnose on the scenario without the effect (for the aerosol: at the scenario's
// 23 km visibility); writes the table as Markdown.
//
//   nvs_validate_scene [--seeds N] [--first S] [--size WxH] [--effects a,b] [--out FILE.md]
//                      [--work DIR] [-v]
//   nvs_validate_scene --write DIR [--effects NAME] [--first SEED]
//       writes one dataset (frames, dataset.toml, its scenario) to DIR and prints the truth

#include <CLI/CLI.hpp>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "rt/compose/scene_stimulus.h"
#include "sim/fit/diagnose.h"
#include "sim/fit/generate_scene.h"
#include "tests/sim/fit/sweep_log.h"

namespace {

using namespace nvs;

struct Row {
    std::string name;
    int n = 0, named = 0, within = 0, none = 0;
    double worstErr = 0.0, seconds = 0.0;
};

fit::SceneStimulusFactory factory(const DataDirs& dirs) {
    return [dirs](const std::filesystem::path& sc, const sensor::CameraParams& cam,
                  const std::filesystem::path& preset, const sensor::Overrides& settings) {
        return rt::makeSceneStimulus(sc, cam, preset, settings, dirs);
    };
}

std::vector<std::string> split(const std::string& s) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string t;
    while (std::getline(ss, t, ','))
        out.push_back(t);
    return out;
}

int run(int argc, char** argv) {
    int seeds = 20, first = 1, w = 128, h = 96;
    bool verbose = false;
    std::string out, only, write, workDir, size;
    CLI::App app{"The hidden scenario-effect sweep of nvstim diagnose (docs/validation.md)"};
    app.add_option("--seeds", seeds, "seeds per case")->check(CLI::Range(1, 100000));
    app.add_option("--first", first, "the first seed (with --write: the seed)")
        ->check(CLI::Range(1, 1000000));
    app.add_option("--size", size, "frame size WxH (128x96; refraction's setup needs 128x96)");
    app.add_option("--out", out, "write the table as Markdown to this file");
    app.add_option("--effects", only, "cases, comma-separated; null: none hidden");
    app.add_option("--work", workDir, "folder for the generated scenarios (one per sweep)");
    app.add_option("--write", write, "write one generated dataset to this folder");
    app.add_flag("-v", verbose, "one line per seed, and the scenario effects' trials");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    if (!size.empty()) fit::test::parseFrameSize(size, w, h);
    const std::filesystem::path src = NVS_SOURCE_DIR;
    const DataDirs dirs{src / "config", std::filesystem::path(NVS_BINARY_DIR) / "nvstim-cache"};
    const auto make = factory(dirs);
    auto spec = [&](const std::string& effect, int seed, const std::filesystem::path& work) {
        fit::SceneGenSpec s;
        s.effect = effect == "null" ? "" : effect;
        s.seed = static_cast<std::uint64_t>(seed);
        s.width = w;
        s.height = h;
        s.sceneFile = src / "scenarios" / "rit" / "scene.toml";
        s.workDir = work;
        return s;
    };
    if (!write.empty()) {
        const fit::Generated g =
            fit::generateScene(spec(only.empty() ? "null" : only, first, write), make, dirs.config);
        fit::writeDataset(g.data, write);
        for (const auto& [k, v] : g.truth)
            std::printf("%s = %.6g\n", k.c_str(), v);
        return 0;
    }
    std::vector<std::string> cases = {"null", "lunar_sky_scatter", "refraction",
                                      "cloud_transmission", "aerosol_extinction"};
    if (!only.empty()) cases = split(only);
    // Two sweeps at once need two work folders (each dataset's scenario is written there).
    const std::filesystem::path work =
        workDir.empty() ? std::filesystem::path(NVS_BINARY_DIR) / "validate-scene"
                        : std::filesystem::path(workDir);
    std::vector<Row> rows;
    for (const std::string& c : cases) {
        Row row;
        row.name = c;
        const auto t0 = std::chrono::steady_clock::now();
        for (int s = first; s < first + seeds; ++s) {
            const fit::Generated g = fit::generateScene(spec(c, s, work), make, dirs.config);
            const fit::Result r = fit::diagnose(g.data, dirs.config);
            ++row.n;
            if (c == "null") {
                row.none += r.findings.empty() ? 1 : 0;
            } else if (!r.findings.empty() && r.findings[0].effect == c) {
                ++row.named;
                double err = 0.0;
                for (const auto& [k, v] : g.truth)
                    for (const auto& [pk, pv] : r.findings[0].parameters)
                        if (k == c + "." + pk) err = std::max(err, std::fabs(pv - v) / v);
                row.within += err <= 0.2 ? 1 : 0;
                row.worstErr = std::max(row.worstErr, err);
            }
            if (verbose) {
                fit::test::logSeed(c, s, g.truth, r);
                for (const auto& t : r.trials)
                    if (t.effect == "lunar_sky_scatter" || t.effect == "refraction" ||
                        t.effect == "cloud_transmission" || t.effect == "aerosol_extinction")
                        std::fprintf(stderr, "    %s z=%.2f rms %.4f->%.4f %s\n", t.effect.c_str(),
                                     t.z, t.before, t.after, t.why.c_str());
            }
        }
        row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        rows.push_back(row);
        std::fprintf(stderr, "%s: done in %.1f s\n", c.c_str(), row.seconds);
    }
    std::ostringstream md;
    md << "| hidden | seeds | top finding names it | parameter within 20 % | worst parameter "
          "error | no finding | time [s] |\n|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
        char buf[400];
        if (r.name == "null")
            std::snprintf(buf, sizeof buf, "| (none) | %d | | | | %d/%d (%.0f %%) | %.1f |\n", r.n,
                          r.none, r.n, 100.0 * r.none / r.n, r.seconds);
        else
            std::snprintf(buf, sizeof buf,
                          "| %s | %d | %d/%d (%.0f %%) | %d/%d (%.0f %%) | %.1f %% | | %.1f |\n",
                          r.name.c_str(), r.n, r.named, r.n, 100.0 * r.named / r.n, r.within, r.n,
                          100.0 * r.within / r.n, 100.0 * r.worstErr, r.seconds);
        md << buf;
    }
    std::printf("%s", md.str().c_str());
    if (!out.empty()) std::ofstream(out) << md.str();
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return nvs::fit::test::mainOf("nvs_validate_scene", run, argc, argv);
}
