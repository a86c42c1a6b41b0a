#include "rt/sweep/gather.h"

#include <fstream>
#include <set>
#include <sstream>

#include "rt/sweep/folder.h"
#include "rt/sweep/json.h"
#include "rt/sweep/metrics.h"
#include "rt/sweep/process.h"
#include "rt/sweep/task.h"
#include "sim/core/error.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

std::vector<std::string> resultColumns(const std::vector<std::string>& axes, bool run) {
    std::vector<std::string> c = {"index"};
    c.insert(c.end(), axes.begin(), axes.end());
    c.push_back("status");
    c.push_back("exit_status");
    if (run) {
        const auto& m = runMetricNames();
        c.insert(c.end(), m.begin(), m.end());
    }
    c.push_back("wall_s");
    c.push_back("host");
    c.push_back("error");
    return c;
}

fs::path plotScriptFor(const fs::path& configDir) {
    std::error_code ec;
    const fs::path installed = configDir / "tools" / "sweep_plots.py";
    if (fs::is_regular_file(installed, ec)) return installed;
    const fs::path source = NVS_SWEEP_PLOTS_SOURCE;
    if (fs::is_regular_file(source, ec)) return source;
    return {};
}

std::string csvField(const std::string& text) {
    if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
    std::string out = "\"";
    for (const char c : text)
        out += c == '"' ? std::string("\"\"") : std::string(1, c);
    return out + "\"";
}

namespace {

// A row: the value of each column (a null Json where the job has none).
Json rowOf(const Job& job, const SweepInfo& info, const Json& result) {
    Json row = Json::object();
    row.set("index", Json::number(static_cast<double>(job.index)));
    for (const std::string& a : info.axes)
        row.set(a, Json::string(axisValue(job, a)));
    if (result.isNull()) {
        row.set("status", Json::string("missing"));
        row.set("error", Json::string("no result.json: the job did not finish"));
        return row;
    }
    row.set("status", Json::string(result.stringOr("status", "failed")));
    if (const Json* v = result.find("exit_status")) row.set("exit_status", *v);
    if (const Json* m = result.find("metrics"); m != nullptr && m->isObject())
        for (const auto& [k, v] : m->members())
            row.set(k, v);
    if (const Json* v = result.find("wall_s")) row.set("wall_s", *v);
    if (const Json* v = result.find("host")) row.set("host", *v);
    row.set("error", Json::string(result.stringOr("error", "")));
    return row;
}

std::string cellText(const Json* v) {
    if (v == nullptr || v->isNull()) return "";
    if (v->isString()) return v->asString();
    return v->dump();
}

// The axes whose values differ between jobs: the plots' x axes.
std::vector<std::string> variedAxes(const std::vector<Job>& jobs, const SweepInfo& info) {
    std::vector<std::string> varied;
    for (const std::string& a : info.axes) {
        std::set<std::string> values;
        for (const Job& j : jobs)
            values.insert(axisValue(j, a));
        if (values.size() > 1) varied.push_back(a);
    }
    return varied;
}

// The concat file of a command sweep: the first job's whole, the others' without the header.
void writeConcat(const fs::path& dir, const SweepInfo& info, const std::vector<Job>& jobs,
                 const std::vector<Json>& results, std::FILE* log) {
    std::string joined;
    bool first = true;
    for (std::size_t i = 0; i < jobs.size(); ++i) {
        const fs::path part = fs::path(jobs[i].dir) / info.concat;
        std::ifstream in(part, std::ios::binary);
        if (results[i].isNull() || results[i].stringOr("status", "") != "ok" || !in) {
            if (log != nullptr) {
                std::fprintf(log, "nvstim sweep: %s: left out of %s (job %lld did not succeed)\n",
                             part.string().c_str(), info.concat.c_str(),
                             static_cast<long long>(jobs[i].index));
            }
            continue;
        }
        std::string line;
        int n = 0;
        while (std::getline(in, line)) {
            if (first || n >= info.concatHeaderLines) joined += line + "\n";
            ++n;
        }
        first = false;
    }
    if (!first) writeFileAtomic(dir / info.concat, joined);
}

void drawPlots(const fs::path& dir, const fs::path& script, std::FILE* log) {
    std::error_code ec;
    // Debian's python3, which python3-matplotlib is installed for, before any other on PATH.
    const std::string python = fs::exists("/usr/bin/python3", ec) ? "/usr/bin/python3" : "python3";
    std::string out, err;
    const int rc = runCapture({python, script.string(), dir.string()}, &out, &err);
    if (rc != 0 && log != nullptr) {
        while (!err.empty() && err.back() == '\n')
            err.pop_back();
        const auto nl = err.rfind('\n');
        std::fprintf(log,
                     "nvstim sweep: plots not drawn (%s, status %d: %s; it needs Debian's "
                     "python3-matplotlib); the table is written\n",
                     script.string().c_str(), rc,
                     (nl == std::string::npos ? err : err.substr(nl + 1)).c_str());
    }
}

}  // namespace

GatherCounts gatherSweep(const fs::path& dir, const fs::path& plotScript, std::FILE* log) {
    const SweepInfo info = readInfo(dir);
    const std::vector<Job> jobs = readManifest(dir / "manifest.jsonl");
    const bool run = info.kind == JobKind::Run;
    const std::vector<std::string> columns = resultColumns(info.axes, run);

    GatherCounts counts;
    std::vector<Json> results;
    Json rows = Json::array();
    std::string csv;
    for (std::size_t c = 0; c < columns.size(); ++c)
        csv += (c == 0 ? "" : ",") + csvField(columns[c]);
    csv += "\n";
    for (const Job& job : jobs) {
        results.push_back(readResult(job));
        const Json row = rowOf(job, info, results.back());
        const std::string status = row.stringOr("status", "");
        if (status == "ok") {
            ++counts.ok;
        } else if (status == "missing") {
            ++counts.missing;
        } else {
            ++counts.failed;
        }
        for (std::size_t c = 0; c < columns.size(); ++c)
            csv += (c == 0 ? "" : ",") + csvField(cellText(row.find(columns[c])));
        csv += "\n";
        rows.push(row);
    }

    Json table = Json::object();
    table.set("sweep", Json::string(info.name));
    table.set("spec", Json::string(info.spec));
    table.set("kind", Json::string(run ? "run" : "command"));
    Json cols = Json::array(), axes = Json::array(), varied = Json::array(),
         metrics = Json::array(), timing = Json::array();
    for (const std::string& c : columns)
        cols.push(Json::string(c));
    for (const std::string& a : info.axes)
        axes.push(Json::string(a));
    for (const std::string& a : variedAxes(jobs, info))
        varied.push(Json::string(a));
    // The numeric metrics, the plots' y axes.
    if (run) {
        for (const std::string& m : runMetricNames())
            if (m != "frames_fnv") metrics.push(Json::string(m));
    }
    metrics.push(Json::string("wall_s"));
    for (const std::string& c : columns)
        if (timingColumn(c)) timing.push(Json::string(c));
    table.set("columns", cols);
    table.set("axes", axes);
    table.set("varied", varied);
    table.set("metrics", metrics);
    table.set("timing_columns", timing);
    // The rows last, one a line.
    std::string json = table.dump();
    json.pop_back();
    json += ",\"rows\":[";
    for (std::size_t i = 0; i < rows.items().size(); ++i)
        json += (i == 0 ? "\n" : ",\n") + rows.items()[i].dump();
    json += "\n]}\n";
    writeFileAtomic(dir / "results.csv", csv);
    writeFileAtomic(dir / "results.json", json);
    if (!info.concat.empty()) writeConcat(dir, info, jobs, results, log);
    if (!plotScript.empty()) drawPlots(dir, plotScript, log);
    return counts;
}

}  // namespace nvs::rt::sweep
