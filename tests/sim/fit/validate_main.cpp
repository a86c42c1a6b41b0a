// The hidden-effect sweep behind `make validate` (docs/validation.md, "diagnose"): for each
// catalog effect (and the null case, and pairs), N seeds of generated datasets (generate.h),
// diagnose on the model without the effect; counts how often the top finding names it, how
// often its parameters come back within 20 %, and writes the table as Markdown.
//
//   nvs_validate_diagnose [--seeds N] [--size WxH] [--effects a,b,...] [--out FILE.md] [-v]
//   nvs_validate_diagnose --write DIR [--effects a+b] [--seeds SEED] [--size WxH]
//                         [--blocks B] [--hold H]   (B stimuli held H frames each)
//       writes one generated dataset (seed SEED) to DIR and prints its hidden truth

#include <CLI/CLI.hpp>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include "sim/fit/diagnose.h"
#include "sim/fit/generate.h"
#include "tests/sim/fit/sweep_log.h"

namespace {

std::vector<std::string> split(const std::string& s, char c) {
    std::vector<std::string> out;
    std::stringstream ss(s);
    std::string t;
    while (std::getline(ss, t, c))
        out.push_back(t);
    return out;
}

struct Row {
    std::string name;
    int n = 0, named = 0, within = 0, allNamed = 0, none = 0;
    double worstErr = 0.0;
    double seconds = 0.0;
};

// Relative error of each true parameter that the finding reports (the worst one).
double paramError(const nvs::fit::Finding& f, const std::map<std::string, double>& truth) {
    double worst = 0.0;
    for (const auto& [k, v] : truth) {
        if (k.rfind(f.effect + ".", 0) != 0) continue;
        const std::string p = k.substr(f.effect.size() + 1);
        for (const auto& [pk, pv] : f.parameters)
            if (pk == p) worst = std::max(worst, std::fabs(pv - v) / std::fabs(v));
    }
    return worst;
}

int run(int argc, char** argv) {
    int seeds = 20, w = 128, h = 96, blocks = 8, hold = 6;
    bool verbose = false;
    std::string out, only, size, writeDir;
    CLI::App app{"The hidden-effect sweep of nvstim diagnose (docs/validation.md)"};
    app.add_option("--seeds", seeds, "seeds per case (with --write: the seed)")
        ->check(CLI::Range(1, 100000));
    app.add_option("--size", size, "frame size WxH (128x96)");
    app.add_option("--out", out, "write the table as Markdown to this file");
    app.add_option("--effects", only, "cases, comma-separated; a pair as a+b; null: none hidden");
    app.add_option("--blocks", blocks, "with --write: stimuli")->check(CLI::Range(1, 10000));
    app.add_option("--hold", hold, "with --write: frames per stimulus")
        ->check(CLI::Range(1, 10000));
    app.add_option("--write", writeDir, "write one generated dataset to this folder");
    app.add_flag("-v", verbose, "one line per seed");
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        return app.exit(e) == 0 ? 0 : 2;
    }
    if (!size.empty()) nvs::fit::test::parseFrameSize(size, w, h);
    if (!writeDir.empty()) out = "write:" + writeDir;
    const std::filesystem::path config = NVS_SOURCE_DIR "/config";
    if (out.rfind("write:", 0) == 0) {
        // One generated dataset written to a folder (seed 1, the first case of --effects).
        nvs::fit::GenSpec spec;
        if (!only.empty() && only != "null") spec.effects = split(split(only, ',')[0], '+');
        spec.seed = static_cast<std::uint64_t>(seeds);
        spec.width = w;
        spec.height = h;
        spec.stimuli = blocks;
        spec.hold = hold;
        const nvs::fit::Generated g = nvs::fit::generate(spec, config);
        nvs::fit::writeDataset(g.data, out.substr(6));
        for (const auto& [k, v] : g.truth)
            std::printf("%s = %.6g\n", k.c_str(), v);
        return 0;
    }
    std::vector<std::string> cases = {"null",
                                      "phosphor_persistence",
                                      "halo",
                                      "fixed_pattern_noise",
                                      "mcp_saturation",
                                      "bright_source_protection",
                                      "veiling_glare",
                                      "vertical_smear",
                                      "ebi_background",
                                      "excess_noise",
                                      "frame_grabber_blur",
                                      "video_streak",
                                      "halo+phosphor_persistence",
                                      "halo+mcp_saturation",
                                      "vertical_smear+excess_noise"};
    if (!only.empty()) cases = split(only, ',');
    std::vector<Row> rows;
    for (const std::string& c : cases) {
        Row row;
        row.name = c;
        const std::vector<std::string> effects =
            c == "null" ? std::vector<std::string>{} : split(c, '+');
        const auto t0 = std::chrono::steady_clock::now();
        for (int s = 1; s <= seeds; ++s) {
            nvs::fit::GenSpec spec;
            spec.effects = effects;
            spec.seed = static_cast<std::uint64_t>(s);
            spec.width = w;
            spec.height = h;
            const nvs::fit::Generated g = nvs::fit::generate(spec, config);
            const nvs::fit::Result r = nvs::fit::diagnose(g.data, config);
            ++row.n;
            if (effects.empty()) {
                row.none += r.findings.empty() ? 1 : 0;
            } else {
                // Named only: a candidate (explained better by unexplained structure) or an
                // unexplained structure does not name a cause.
                auto named = [](const nvs::fit::Finding& f) { return f.status == "named"; };
                const bool top = !r.findings.empty() && r.findings[0].effect == effects[0] &&
                                 named(r.findings[0]);
                bool all = true;
                double err = 0.0;
                for (const std::string& e : effects) {
                    bool found = false;
                    for (const auto& f : r.findings)
                        if (f.effect == e && named(f)) {
                            found = true;
                            err = std::max(err, paramError(f, g.truth));
                        }
                    all = all && found;
                }
                const bool anyTop = !r.findings.empty() && named(r.findings[0]) &&
                                    std::find(effects.begin(), effects.end(),
                                              r.findings[0].effect) != effects.end();
                row.named += (effects.size() == 1 ? top : anyTop) ? 1 : 0;
                row.allNamed += all ? 1 : 0;
                row.within += all && err <= 0.2 ? 1 : 0;
                row.worstErr = std::max(row.worstErr, all ? err : 0.0);
            }
            if (verbose) {
                nvs::fit::test::logSeed(c, s, g.truth, r);
                if (verbose && argc > 0 && std::getenv("NVS_VALIDATE_TRIALS")) {
                    for (const auto& t : r.trials)
                        std::fprintf(stderr, "    %s z=%.2f score=%.1f rms %.4f->%.4f %s\n",
                                     t.effect.c_str(), t.z, t.score, t.before, t.after,
                                     t.why.c_str());
                    for (const auto& [k, v] : r.baseline)
                        std::fprintf(stderr, "    baseline %s=%.4g\n", k.c_str(), v);
                }
            }
        }
        row.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        rows.push_back(row);
        std::fprintf(stderr, "%s: done in %.1f s\n", c.c_str(), row.seconds);
    }
    std::ostringstream md;
    md << "| hidden | seeds | top finding names it | all named | parameters within 20 % | worst "
          "parameter error | no finding | time [s] |\n"
       << "|---|---|---|---|---|---|---|---|\n";
    for (const Row& r : rows) {
        char buf[400];
        if (r.name == "null")
            std::snprintf(buf, sizeof buf, "| (none) | %d | | | | | %d/%d (%.0f %%) | %.1f |\n",
                          r.n, r.none, r.n, 100.0 * r.none / r.n, r.seconds);
        else
            std::snprintf(
                buf, sizeof buf,
                "| %s | %d | %d/%d (%.0f %%) | %d/%d | %d/%d (%.0f %%) | %.1f %% | | %.1f |\n",
                r.name.c_str(), r.n, r.named, r.n, 100.0 * r.named / r.n, r.allNamed, r.n, r.within,
                r.n, 100.0 * r.within / r.n, 100.0 * r.worstErr, r.seconds);
        md << buf;
    }
    std::printf("%s", md.str().c_str());
    if (!out.empty()) std::ofstream(out) << md.str();
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    return nvs::fit::test::mainOf("nvs_validate_diagnose", run, argc, argv);
}
