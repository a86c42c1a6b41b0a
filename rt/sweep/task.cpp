#include "rt/sweep/task.h"

#include <unistd.h>

#include <cstdio>
#include <fstream>
#include <sstream>

#include "rt/sweep/metrics.h"
#include "rt/sweep/process.h"
#include "rt/sweep/seeded_scenario.h"
#include "sim/core/error.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

std::string hostName() {
    char buf[256] = {};
    if (::gethostname(buf, sizeof buf - 1) != 0) return "?";
    std::string h = buf;
    const auto dot = h.find('.');
    return dot == std::string::npos ? h : h.substr(0, dot);
}

fs::path resultPath(const Job& job) {
    return fs::path(job.dir) / "result.json";
}

void writeResult(const Job& job, const Json& result) {
    const fs::path final = resultPath(job);
    const fs::path temp = final.string() + ".tmp" + std::to_string(::getpid());
    {
        std::ofstream out(temp, std::ios::binary | std::ios::trunc);
        out << result.dump() << "\n";
        out.flush();
        if (!out) throw std::runtime_error(temp.string() + ": cannot write");
    }
    fs::rename(temp, final);
}

Json readResult(const Job& job) {
    std::ifstream in(resultPath(job), std::ios::binary);
    if (!in) return Json();
    std::ostringstream text;
    text << in.rdbuf();
    try {
        Json r = parseJson(text.str(), resultPath(job).string());
        return r.isObject() ? r : Json();
    } catch (const SetupError&) {
        return Json();
    }
}

namespace {

Json baseResult(const Job& job) {
    Json r = Json::object();
    r.set("index", Json::number(static_cast<double>(job.index)));
    r.set("host", Json::string(hostName()));
    return r;
}

// Clears what an earlier attempt of this job left in its folder (the folder is the sweep's).
void clearAttempt(const Job& job) {
    std::error_code ec;
    fs::remove_all(fs::path(job.dir) / "frames", ec);
    for (const char* f : {"stats.json", "result.json", "stdout.txt", "stderr.txt"})
        fs::remove(fs::path(job.dir) / f, ec);
}

}  // namespace

int runTask(const fs::path& manifest, std::int64_t index, const fs::path& nvstim,
            std::atomic<bool>* stop) {
    const std::vector<Job> jobs = readManifest(manifest);
    if (index < 0 || index >= static_cast<std::int64_t>(jobs.size())) {
        throw SetupError("--task " + std::to_string(index) + ": the manifest has " +
                         std::to_string(jobs.size()) + " jobs (0.." +
                         std::to_string(static_cast<long long>(jobs.size()) - 1) + ")");
    }
    const Job& job = jobs[static_cast<std::size_t>(index)];
    fs::create_directories(job.dir);
    clearAttempt(job);
    Json result = baseResult(job);

    SpawnSpec child;
    child.cwd = job.cwd;
    child.stdoutFile = (fs::path(job.dir) / "stdout.txt").string();
    child.stderrFile = (fs::path(job.dir) / "stderr.txt").string();
    if (job.kind == JobKind::Run) {
        child.argv.push_back(nvstim.string());
        if (job.seed) {
            try {
                writeSeededScenario(job.scenarioPath, *job.seed, runScenarioArg(job));
            } catch (const SetupError& e) {
                result.set("status", Json::string("failed"));
                result.set("exit_status", Json::number(2));
                result.set("wall_s", Json::number(0));
                result.set("error", Json::string(std::string("seeded scenario: ") + e.what()));
                writeResult(job, result);
                return kTaskJobFailed;
            }
        }
    }
    child.argv.insert(child.argv.end(), job.argv.begin(), job.argv.end());

    const ChildOutcome o = runChildFor(child, job.timeout_s, stop);
    if (o.stopped) return kTaskInterrupted;
    std::string status = o.status == 0 ? "ok" : (o.timedOut ? "timeout" : "failed");
    result.set("exit_status", Json::number(o.status));
    result.set("wall_s", Json::number(o.wall_s));
    std::string error;
    if (o.status < 0) {
        error = "could not start " + child.argv[0];
    } else if (o.status != 0) {
        error = fileTail(child.stderrFile, 3, 400);
        if (o.timedOut)
            error = "stopped after timeout_s " + jsonNumber(job.timeout_s) + " s" +
                    (error.empty() ? "" : ": " + error);
    }
    if (job.kind == JobKind::Run && status == "ok") {
        try {
            result.set("metrics",
                       measureRun(fs::path(job.dir) / "frames", fs::path(job.dir) / "stats.json"));
        } catch (const SetupError& e) {
            status = "failed";
            error = std::string("measuring: ") + e.what();
        }
        if (!job.keepFrames) {
            std::error_code ec;
            fs::remove_all(fs::path(job.dir) / "frames", ec);
        }
    }
    result.set("status", Json::string(status));
    result.set("error", Json::string(error));
    writeResult(job, result);
    return status == "ok" ? kTaskOk : kTaskJobFailed;
}

}  // namespace nvs::rt::sweep
