// nvstim diagnose: fit the camera model to a measured dataset and name what it gets wrong
// (docs/design.md §8, docs/contracts.md "diagnose", docs/diagnose.md).
//
//   nvstim diagnose DATASET_DIR [--json OUT] [--report DIR] [--write-preset FILE] [--seed S]
//   nvstim diagnose DATASET_DIR --compare PRESET_A PRESET_B [--json OUT] [--report DIR]
//
// With --report and --write-preset the report also shows the gain of the written preset (the
// dataset's preset against it, as --compare does).
//
// The dataset and every output path are checked before any work (sim/core/output_file.h): a bad
// dataset or output is one line on stderr and exit 2 with nothing written. Progress goes to
// stderr; the JSON goes to stdout and, with --json, to OUT. All outputs are written under
// temporary names and renamed into place together at the end; the report folder is new or a
// previous report (marked by kReportMarker), never any other folder. The report's
// plots are drawn by config/tools/diagnose_report.py with Matplotlib (Debian
// python3-matplotlib).

#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/diagnose/diagnose_dataset.h"
#include "sim/core/error.h"
#include "sim/core/input_file.h"
#include "sim/core/output_file.h"
#include "sim/fit/compare.h"
#include "sim/fit/diagnose.h"
#include "sim/fit/text.h"
#include "sim/io/pnm.h"

namespace nvs::cli {

namespace {

namespace fs = std::filesystem;

// The file that marks a folder as a report of `nvstim diagnose --report`: only such a folder
// is ever replaced by a new report.
constexpr const char* kReportMarker = ".nvstim-diagnose-report";

// Runs the plotting script on the report folder; returns its exit status.
int runPlotter(const fs::path& script, const fs::path& dir) {
    // Debian's python3, which python3-matplotlib is installed for, before any other on PATH.
    const char* python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
    return runChild({python, script.string(), dir.string()});
}

// `reportJson` is report.json's text; the maps of `r` are written beside it as PFM.
void writeReport(const fit::Result& r, const std::string& reportJson, const fs::path& dir,
                 const fs::path& script, OutputFiles& outputs) {
    outputs.writeWith(dir, [&](const fs::path& tmp) {
        std::ofstream out(tmp / "report.json");
        out << reportJson << "\n";
        out.close();
        if (!out) throw std::runtime_error("cannot write report.json");
        for (const auto& [name, plane] : r.maps) {
            ImageF img(r.width, r.height);
            for (int y = 0; y < r.height; ++y)
                for (int x = 0; x < r.width; ++x)
                    img(x, y) = plane[static_cast<std::size_t>(y) * r.width + x];
            io::writePfm(tmp / (name + ".pfm"), img.cview());
        }
        const int rc = runPlotter(script, tmp);
        if (rc != 0) {
            throw std::runtime_error(script.string() + " failed (status " + std::to_string(rc) +
                                     "; it needs Debian's python3-matplotlib); no output written");
        }
    });
}

// The comparison's report.json: the dataset and the comparison (diagnose_report.py draws it).
std::string compareReportJson(const fit::Comparison& c, const std::string& dataset) {
    return "{\"dataset\":" + fit::jsonString(dataset) + "," + fit::toJson(c).substr(1);
}

// The gain of the preset --write-preset writes, for the report: the dataset's preset against
// it on the held-out frames (written to a temporary file, removed after).
std::string gainOfWrittenPreset(const fit::Dataset& d, const fit::Result& r, const DataDirs& dirs,
                                const fit::Options& o, const fit::Progress& progress) {
    const fs::path tmp = fs::temp_directory_path() /
                         ("nvstim-diagnose-" + std::to_string(::getpid()) + "-preset.toml");
    {
        std::ofstream out(tmp);
        out << fit::presetWithFindings(d.presetFile, r);
        if (!out) throw std::runtime_error(tmp.string() + ": cannot write the written preset");
    }
    progress("the gain of the written preset: " + d.presetFile.filename().string() + " against it");
    std::string j;
    try {
        const sensor::Overrides settings = fit::settingsWithoutFindings(d, r);
        j = fit::toJson(fit::compareModels(d, dirs.config, d.presetFile.string(), tmp.string(), o,
                                           progress, &settings));
    } catch (...) {
        fs::remove(tmp);
        throw;
    }
    fs::remove(tmp);
    return j;
}

}  // namespace

int runDiagnose(const DiagnoseOptions& opts) {
    const DataDirs dirs = resolveDataDirs();
    // Every output checked before any work, against each other and the dataset.
    OutputFiles outputs;
    if (!isDirectory(opts.datasetDir))
        throw SetupError(opts.datasetDir + ": not a dataset folder (no such folder)");
    outputs.addInput(opts.datasetDir);
    if (opts.json) outputs.addFile("--json", *opts.json);
    if (opts.writePreset) outputs.addFile("--write-preset", *opts.writePreset);
    if (opts.report) outputs.addFolder("--report", *opts.report, kReportMarker);
    const fs::path script = dirs.config / "tools" / "diagnose_report.py";
    if (opts.report) requireRegularFile(script, "--report: plotting script");
    const auto t0 = std::chrono::steady_clock::now();
    auto progress = [&](const std::string& line) {
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::fprintf(stderr, "nvstim diagnose: [%6.1f s] %s\n", s, line.c_str());
    };
    // No progress while reading radiance files: a bad dataset is one line on stderr. A
    // scenario stimulus is rendered while reading, which takes a while: that says so.
    const fit::Dataset d = rt::loadDiagnoseDataset(opts.datasetDir, dirs, progress);
    outputs.addInput(d.presetFile);
    progress("dataset: " + std::to_string(d.frameCount()) + " frames " + std::to_string(d.width) +
             "x" + std::to_string(d.height) + ", " + std::to_string(d.stimuli.size()) +
             " distinct stimuli, camera " + d.camera.name);
    fit::Options o;
    o.seed = opts.seed;
    if (!opts.compare.empty()) {
        const fit::Comparison c =
            fit::compareModels(d, dirs.config, opts.compare[0], opts.compare[1], o, progress);
        const std::string json = fit::toJson(c);
        outputs.holdSignals();
        if (opts.json) outputs.writeText(*opts.json, json + "\n");
        if (opts.report)
            writeReport(fit::Result{}, compareReportJson(c, opts.datasetDir), *opts.report, script,
                        outputs);
        outputs.commit();
        std::printf("%s\n", json.c_str());
        return kExitOk;
    }
    const fit::Result r = fit::diagnose(d, dirs.config, o, progress);
    std::string report;
    if (opts.report) {
        report = fit::reportJson(r, opts.datasetDir);
        bool named = false;
        for (const fit::Finding& f : r.findings)
            named = named || f.status == "named";
        if (opts.writePreset && named)
            report = report.substr(0, report.size() - 1) +
                     ",\"gain_of_written_preset\":" + gainOfWrittenPreset(d, r, dirs, o, progress) +
                     "}";
    }
    const std::string json = fit::toJson(r);
    {
        // All outputs or none; a signal meanwhile leaves none and no temporary.
        outputs.holdSignals();
        if (opts.json) outputs.writeText(*opts.json, json + "\n");
        if (opts.writePreset)
            outputs.writeText(*opts.writePreset, fit::presetWithFindings(d.presetFile, r));
        if (opts.report) writeReport(r, report, *opts.report, script, outputs);
        outputs.commit();
    }
    progress(r.findings.empty() ? "no finding"
                                : std::to_string(r.findings.size()) +
                                      " finding(s), first: " + r.findings.front().effect);
    std::printf("%s\n", json.c_str());
    return kExitOk;
}

}  // namespace nvs::cli
