#include "rt/sweep/manifest.h"

#include <cstdio>
#include <fstream>
#include <map>
#include <sstream>

#include "rt/sweep/json.h"
#include "sim/core/error.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

std::string jobDirName(std::int64_t index) {
    char buf[32];
    std::snprintf(buf, sizeof buf, "jobs/%06lld", static_cast<long long>(index));
    return buf;
}

std::string runScenarioArg(const Job& job) {
    return job.seed ? (fs::path(job.dir) / "scenario.toml").string() : job.scenarioPath;
}

namespace {

// The arguments of `nvstim run` for a job of kind run (after the binary's name).
std::vector<std::string> runArgv(const Job& job, const std::vector<std::string>& extra) {
    std::vector<std::string> a = {"run", runScenarioArg(job), "--clock",
                                  "sim", "--frames",          std::to_string(job.frames)};
    if (!job.presetArg.empty()) {
        a.push_back("--camera");
        a.push_back(job.presetArg);
    }
    for (const auto& [k, v] : job.set) {
        a.push_back("--set");
        a.push_back(k + "=" + v);
    }
    a.insert(a.end(), extra.begin(), extra.end());
    a.push_back("--output");
    a.push_back("pgm:" + (fs::path(job.dir) / "frames").string());
    a.push_back("--stats");
    a.push_back((fs::path(job.dir) / "stats.json").string());
    return a;
}

// The values of a command's placeholders for one job.
std::map<std::string, std::string> placeholders(const SweepSpec& spec, const Job& job,
                                                const fs::path& outDir) {
    std::map<std::string, std::string> v = spec.vars;
    v["index"] = std::to_string(job.index);
    v["job_dir"] = job.dir;
    v["out"] = outDir.string();
    v["spec_dir"] = spec.file.parent_path().string();
    v["scenario"] = job.scenarioPath;
    v["preset"] = job.presetArg;
    v["seed"] = job.seed ? std::to_string(*job.seed) : "";
    for (const auto& [k, val] : job.set)
        v[k] = val;
    return v;
}

}  // namespace

std::vector<Job> expandJobs(const SweepSpec& spec, const fs::path& outDir, const fs::path& cwd) {
    // An absent axis is one empty value.
    const std::vector<std::string> none = {""};
    const std::vector<std::string>& scenarios = spec.scenarios.empty() ? none : spec.scenarios;
    const std::vector<std::string>& presets = spec.presets.empty() ? none : spec.presets;
    std::vector<std::optional<std::uint64_t>> seeds;
    for (const std::uint64_t s : spec.seeds)
        seeds.emplace_back(s);
    if (seeds.empty()) seeds.emplace_back(std::nullopt);
    // The [set] product as an odometer, the last key turning fastest.
    std::size_t setCombos = 1;
    for (const auto& [k, values] : spec.sets)
        setCombos *= values.size();

    std::vector<Job> jobs;
    for (std::size_t si = 0; si < scenarios.size(); ++si) {
        for (std::size_t pi = 0; pi < presets.size(); ++pi) {
            for (std::size_t combo = 0; combo < setCombos; ++combo) {
                std::vector<std::pair<std::string, std::string>> set(spec.sets.size());
                std::size_t rest = combo;
                for (std::size_t k = spec.sets.size(); k-- > 0;) {
                    const auto& values = spec.sets[k].second;
                    set[k] = {spec.sets[k].first, values[rest % values.size()]};
                    rest /= values.size();
                }
                for (const auto& seed : seeds) {
                    Job job;
                    job.index = static_cast<std::int64_t>(jobs.size());
                    job.kind = spec.kind;
                    job.dir = (outDir / jobDirName(job.index)).string();
                    job.cwd = cwd.string();
                    if (!spec.scenarios.empty()) {
                        job.scenario = scenarios[si];
                        job.scenarioPath = spec.scenarioPaths[si];
                    }
                    if (!spec.presets.empty()) {
                        job.preset = presets[pi];
                        job.presetArg = spec.presetArgs[pi];
                    }
                    job.seed = seed;
                    job.set = set;
                    job.frames = spec.frames;
                    job.timeout_s = spec.timeout_s;
                    job.keepFrames = spec.keepFrames;
                    if (spec.kind == JobKind::Run) {
                        job.argv = runArgv(job, spec.runArgs);
                    } else {
                        const auto values = placeholders(spec, job, outDir);
                        for (const std::string& a : spec.argv)
                            job.argv.push_back(
                                expandPlaceholders(a, values, spec.file.string() + ": argv"));
                    }
                    jobs.push_back(std::move(job));
                }
            }
        }
    }
    return jobs;
}

std::string jobLine(const Job& job) {
    Json o = Json::object();
    o.set("index", Json::number(static_cast<double>(job.index)));
    o.set("kind", Json::string(job.kind == JobKind::Run ? "run" : "command"));
    o.set("dir", Json::string(job.dir));
    o.set("cwd", Json::string(job.cwd));
    o.set("scenario", Json::string(job.scenario));
    o.set("scenario_path", Json::string(job.scenarioPath));
    o.set("preset", Json::string(job.preset));
    o.set("preset_arg", Json::string(job.presetArg));
    o.set("seed", job.seed ? Json::number(static_cast<double>(*job.seed)) : Json());
    Json set = Json::object();
    for (const auto& [k, v] : job.set)
        set.set(k, Json::string(v));
    o.set("set", set);
    o.set("frames", Json::number(static_cast<double>(job.frames)));
    o.set("timeout_s", Json::number(job.timeout_s));
    o.set("keep_frames", Json::boolean(job.keepFrames));
    Json argv = Json::array();
    for (const std::string& a : job.argv)
        argv.push(Json::string(a));
    o.set("argv", argv);
    return o.dump();
}

Job parseJob(const std::string& line, const std::string& where) {
    const Json o = parseJson(line, where);
    if (!o.isObject()) throw SetupError(where + ": a manifest line must be a JSON object");
    const auto need = [&](const char* key) -> const Json& {
        const Json* v = o.find(key);
        if (v == nullptr) throw SetupError(where + ": no \"" + key + "\"");
        return *v;
    };
    Job job;
    job.index = static_cast<std::int64_t>(need("index").asNumber());
    const std::string kind = need("kind").asString();
    if (kind != "run" && kind != "command") throw SetupError(where + ": unknown kind " + kind);
    job.kind = kind == "run" ? JobKind::Run : JobKind::Command;
    job.dir = need("dir").asString();
    job.cwd = need("cwd").asString();
    if (job.dir.empty() || job.cwd.empty()) throw SetupError(where + ": empty dir or cwd");
    job.scenario = o.stringOr("scenario", "");
    job.scenarioPath = o.stringOr("scenario_path", "");
    job.preset = o.stringOr("preset", "");
    job.presetArg = o.stringOr("preset_arg", "");
    if (const Json* s = o.find("seed"); s != nullptr && s->isNumber())
        job.seed = static_cast<std::uint64_t>(s->asNumber());
    if (const Json* s = o.find("set"); s != nullptr)
        for (const auto& [k, v] : s->members())
            job.set.emplace_back(k, v.asString());
    job.frames = static_cast<std::int64_t>(o.numberOr("frames", 0));
    job.timeout_s = o.numberOr("timeout_s", 3600.0);
    if (const Json* k = o.find("keep_frames"); k != nullptr) job.keepFrames = k->asBool();
    for (const Json& a : need("argv").items())
        job.argv.push_back(a.asString());
    if (job.argv.empty()) throw SetupError(where + ": empty argv");
    return job;
}

std::string manifestText(const std::vector<Job>& jobs) {
    std::string text;
    for (const Job& j : jobs)
        text += jobLine(j) + "\n";
    return text;
}

std::vector<Job> readManifest(const fs::path& file) {
    std::ifstream in(file);
    if (!in) throw SetupError("--manifest " + file.string() + ": cannot read");
    std::vector<Job> jobs;
    std::string line;
    int n = 0;
    while (std::getline(in, line)) {
        ++n;
        if (line.empty()) continue;
        Job j = parseJob(line, file.string() + ":" + std::to_string(n));
        if (j.index != static_cast<std::int64_t>(jobs.size())) {
            throw SetupError(file.string() + ":" + std::to_string(n) + ": index " +
                             std::to_string(j.index) + " out of order (expected " +
                             std::to_string(jobs.size()) + ")");
        }
        jobs.push_back(std::move(j));
    }
    return jobs;
}

}  // namespace nvs::rt::sweep
