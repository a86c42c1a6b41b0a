#include "rt/sweep/folder.h"

#include <unistd.h>

#include <fstream>
#include <sstream>

#include "rt/sweep/json.h"
#include "sim/core/error.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

namespace {

constexpr const char* kFormat = "nvstim-sweep 1";

std::string slurp(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

Json infoJson(const SweepInfo& info) {
    Json o = Json::object();
    o.set("format", Json::string(kFormat));
    o.set("name", Json::string(info.name));
    o.set("spec", Json::string(info.spec));
    o.set("kind", Json::string(info.kind == JobKind::Run ? "run" : "command"));
    o.set("jobs", Json::number(static_cast<double>(info.jobs)));
    Json axes = Json::array();
    for (const std::string& a : info.axes)
        axes.push(Json::string(a));
    o.set("axes", axes);
    o.set("concat", Json::string(info.concat));
    o.set("concat_header_lines", Json::number(info.concatHeaderLines));
    return o;
}

}  // namespace

void writeFileAtomic(const fs::path& path, const std::string& text) {
    const fs::path temp = path.string() + ".tmp" + std::to_string(::getpid());
    {
        std::ofstream out(temp, std::ios::binary | std::ios::trunc);
        out << text;
        out.flush();
        if (!out) throw std::runtime_error(temp.string() + ": cannot write");
    }
    fs::rename(temp, path);
}

SweepInfo sweepInfo(const SweepSpec& spec, std::int64_t jobs) {
    SweepInfo info;
    info.name = spec.name;
    info.spec = spec.file.string();
    info.kind = spec.kind;
    info.jobs = jobs;
    if (!spec.scenarios.empty()) info.axes.push_back("scenario");
    if (!spec.presets.empty()) info.axes.push_back("preset");
    if (!spec.seeds.empty()) info.axes.push_back("seed");
    for (const auto& [k, v] : spec.sets)
        info.axes.push_back(k);
    info.concat = spec.concat;
    info.concatHeaderLines = spec.concatHeaderLines;
    return info;
}

SweepInfo readInfo(const fs::path& dir) {
    const fs::path file = dir / "sweep.json";
    std::error_code ec;
    if (!fs::is_regular_file(file, ec)) {
        throw SetupError(dir.string() + ": not a sweep folder (no sweep.json)");
    }
    const Json o = parseJson(slurp(file), file.string());
    if (o.stringOr("format", "") != kFormat) {
        throw SetupError(file.string() + ": not a sweep of this nvstim (format \"" +
                         o.stringOr("format", "") + "\", expected \"" + kFormat + "\")");
    }
    SweepInfo info;
    info.name = o.stringOr("name", "");
    info.spec = o.stringOr("spec", "");
    info.kind = o.stringOr("kind", "run") == "run" ? JobKind::Run : JobKind::Command;
    info.jobs = static_cast<std::int64_t>(o.numberOr("jobs", 0));
    if (const Json* axes = o.find("axes"); axes != nullptr)
        for (const Json& a : axes->items())
            info.axes.push_back(a.asString());
    info.concat = o.stringOr("concat", "");
    info.concatHeaderLines = static_cast<int>(o.numberOr("concat_header_lines", 0));
    return info;
}

FolderState prepareFolder(const fs::path& dir, const SweepInfo& info, const std::string& manifest) {
    std::error_code ec;
    const std::string where = "--out " + dir.string();
    if (fs::exists(fs::symlink_status(dir, ec))) {
        if (!fs::is_directory(dir, ec)) throw SetupError(where + ": exists and is not a folder");
        const bool empty = fs::directory_iterator(dir, ec) == fs::directory_iterator();
        if (ec) throw SetupError(where + ": cannot read: " + ec.message());
        if (!empty) {
            if (!fs::is_regular_file(dir / "sweep.json", ec)) {
                throw SetupError(where +
                                 ": not empty and not a sweep folder (no sweep.json); nothing "
                                 "written: give a new or empty folder");
            }
            const SweepInfo old = readInfo(dir);
            if (slurp(dir / "manifest.jsonl") != manifest) {
                throw SetupError(where + ": a sweep of another grid (\"" + old.name + "\", " +
                                 old.spec +
                                 ": its manifest differs: another spec, --var or working "
                                 "folder); nothing written: give another --out");
            }
            return FolderState::Resumed;
        }
    }
    fs::create_directories(dir / "jobs", ec);
    if (ec) throw SetupError(where + ": cannot create: " + ec.message());
    writeFileAtomic(dir / "manifest.jsonl", manifest);
    writeFileAtomic(dir / "sweep.json", infoJson(info).dump() + "\n");
    return FolderState::New;
}

std::string axisValue(const Job& job, const std::string& axis) {
    if (axis == "scenario") return job.scenario;
    if (axis == "preset") return job.preset;
    if (axis == "seed") return job.seed ? std::to_string(*job.seed) : "";
    for (const auto& [k, v] : job.set)
        if (k == axis) return v;
    return "";
}

}  // namespace nvs::rt::sweep
