// nvstim diagnose: fit the camera model to a measured dataset and name what it gets wrong
// (DESIGN §8, docs/contracts.md "diagnose", docs/diagnose.md).
//
//   nvstim diagnose DATASET_DIR [--json OUT] [--report DIR] [--write-preset FILE] [--seed S]
//
// The dataset and every output path are checked before any work: a bad dataset is one line on
// stderr and exit 2 with nothing written. Progress goes to stderr; the JSON goes to stdout and,
// with --json, to OUT. Each file is written under a temporary name and renamed; the report
// folder is filled under a temporary name and renamed into place at the end. The report's
// plots are drawn by config/tools/diagnose_report.py with Matplotlib (Debian
// python3-matplotlib).

#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/compose/scene_stimulus.h"
#include "sim/core/error.h"
#include "sim/fit/diagnose.h"
#include "sim/sensor/image_io.h"

namespace nvs::cli {

namespace {

namespace fs = std::filesystem;

void writeAtomically(const fs::path& file, const std::string& text) {
    const fs::path tmp = file.string() + ".tmp";
    {
        std::ofstream out(tmp);
        out << text;
        if (!out) throw SetupError(file.string() + ": cannot write");
    }
    fs::rename(tmp, file);
}

// An output file's folder must exist before the work starts.
void checkOutput(const std::optional<std::string>& path, const char* option) {
    if (!path) return;
    const fs::path parent = fs::absolute(*path).parent_path();
    if (!fs::is_directory(parent)) {
        throw SetupError(std::string(option) + " " + *path + ": no directory " + parent.string());
    }
}

// Runs the plotting script on the report folder; returns its exit status.
int runPlotter(const fs::path& script, const fs::path& dir) {
    // Debian's python3, which python3-matplotlib is installed for, before any other on PATH.
    const char* python = fs::exists("/usr/bin/python3") ? "/usr/bin/python3" : "python3";
    const pid_t pid = fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        execlp(python, python, script.c_str(), dir.c_str(), static_cast<char*>(nullptr));
        _exit(127);
    }
    int status = 0;
    if (waitpid(pid, &status, 0) < 0) return -1;
    return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

void writeReport(const fit::Result& r, const fs::path& dir, const std::string& dataset,
                 const DataDirs& dirs) {
    const fs::path script = dirs.config / "tools" / "diagnose_report.py";
    if (!fs::exists(script)) throw SetupError("--report: no plotting script " + script.string());
    const fs::path tmp = dir.string() + ".tmp";
    fs::remove_all(tmp);
    fs::create_directories(tmp);
    writeAtomically(tmp / "report.json", fit::reportJson(r, dataset) + "\n");
    for (const auto& [name, plane] : r.maps) {
        ImageF img(r.width, r.height);
        for (int y = 0; y < r.height; ++y)
            for (int x = 0; x < r.width; ++x)
                img(x, y) = plane[static_cast<std::size_t>(y) * r.width + x];
        sensor::writePfm(tmp / (name + ".pfm"), img.cview());
    }
    const int rc = runPlotter(script, tmp);
    if (rc != 0) {
        throw std::runtime_error(
            "--report: " + script.string() + " failed (status " + std::to_string(rc) +
            "; it needs Debian's python3-matplotlib); data left in " + tmp.string());
    }
    fs::remove_all(dir);
    fs::rename(tmp, dir);
}

}  // namespace

int runDiagnose(const DiagnoseOptions& opts) {
    const DataDirs dirs = resolveDataDirs();
    checkOutput(opts.json, "--json");
    checkOutput(opts.writePreset, "--write-preset");
    checkOutput(opts.report, "--report");
    const auto t0 = std::chrono::steady_clock::now();
    auto progress = [&](const std::string& line) {
        const double s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
        std::fprintf(stderr, "nvstim diagnose: [%6.1f s] %s\n", s, line.c_str());
    };
    // No progress while reading radiance files: a bad dataset is one line on stderr. A
    // scenario stimulus is rendered while reading, which takes a while: that says so.
    auto renderScenario = [&](const fs::path& scenario, const sensor::CameraParams& cam,
                              const fs::path& presetFile, const sensor::Overrides& settings) {
        return rt::makeSceneStimulus(scenario, cam, presetFile, settings, dirs);
    };
    const fit::Dataset d = fit::loadDataset(opts.datasetDir, dirs.config, progress, renderScenario);
    progress("dataset: " + std::to_string(d.frameCount()) + " frames " + std::to_string(d.width) +
             "x" + std::to_string(d.height) + ", " + std::to_string(d.stimuli.size()) +
             " distinct stimuli, camera " + d.camera.name);
    fit::Options o;
    o.seed = opts.seed;
    const fit::Result r = fit::diagnose(d, dirs.config, o, progress);
    const std::string json = fit::toJson(r);
    if (opts.json) writeAtomically(*opts.json, json + "\n");
    if (opts.writePreset)
        writeAtomically(*opts.writePreset, fit::presetWithFindings(d.presetFile, r));
    if (opts.report) writeReport(r, *opts.report, opts.datasetDir, dirs);
    progress(r.findings.empty() ? "no finding"
                                : std::to_string(r.findings.size()) +
                                      " finding(s), first: " + r.findings.front().effect);
    std::printf("%s\n", json.c_str());
    return kExitOk;
}

}  // namespace nvs::cli
