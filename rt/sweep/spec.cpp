#include "rt/sweep/spec.h"

#include <algorithm>
#include <cmath>

#include "rt/sweep/json.h"
#include "rt/sweep/metrics.h"
#include "sim/core/config.h"
#include "sim/core/error.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

namespace {

// A name the sweep's own files and Slurm's job name can carry as they are.
bool plainName(const std::string& s) {
    if (s.empty() || s.size() > 64) return false;
    for (const char c : s) {
        const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                        (c >= '0' && c <= '9') || c == '_' || c == '.' || c == '-';
        if (!ok) return false;
    }
    return true;
}

// A placeholder's or axis' name: a C identifier.
bool identifier(const std::string& s) {
    if (s.empty() || (s[0] >= '0' && s[0] <= '9')) return false;
    for (const char c : s) {
        const bool ok = (c >= 'a' && c <= 'z') || (c >= 'A' && c <= 'Z') ||
                        (c >= '0' && c <= '9') || c == '_' || c == '.';
        if (!ok) return false;
    }
    return true;
}

// A table's keys in the order the file writes them (ConfigTable::keys() gives them sorted).
std::vector<std::string> keysInFileOrder(const ConfigTable& t) {
    std::vector<std::string> keys = t.keys();
    std::stable_sort(keys.begin(), keys.end(), [&](const std::string& a, const std::string& b) {
        const FileLoc la = t.location(a), lb = t.location(b);
        return la.line != lb.line ? la.line < lb.line : la.column < lb.column;
    });
    return keys;
}

// The results' own columns (gather.h), which no axis may be named.
bool reservedColumn(const std::string& key) {
    for (const char* c : {"index", "scenario", "preset", "seed", "status", "exit_status", "wall_s",
                          "host", "error"})
        if (key == c) return true;
    for (const std::string& m : runMetricNames())
        if (key == m) return true;
    return false;
}

// As `nvstim run --camera` decides (sim/sensor/camera.cpp resolveCameraPath): a path when it
// ends in .toml or holds a '/', else a name.
bool pathLike(const std::string& s) {
    return s.find('/') != std::string::npos || fs::path(s).extension() == ".toml";
}

// An array of strings, or of numbers written back as their shortest text.
std::vector<std::string> textValues(const ConfigTable& t, const std::string& key) {
    std::vector<std::string> out;
    try {
        out = t.require<std::vector<std::string>>(key);
    } catch (const SetupError&) {
        std::vector<double> numbers;
        try {
            numbers = t.require<std::vector<double>>(key);
        } catch (const SetupError&) {
            t.fail(key, "must be an array of strings or an array of numbers");
        }
        for (const double v : numbers)
            out.push_back(jsonNumber(v));
    }
    if (out.empty()) t.fail(key, "must not be empty");
    return out;
}

std::vector<std::uint64_t> readSeeds(const ConfigTable& root) {
    std::vector<std::uint64_t> seeds;
    if (!root.contains("seeds")) return seeds;
    std::optional<std::int64_t> count;
    try {
        count = root.optional<std::int64_t>("seeds");
    } catch (const SetupError&) {
    }
    if (count) {
        if (*count < 1 || *count > 1000000) root.fail("seeds", "a count must be in 1..1000000");
        for (std::int64_t s = 1; s <= *count; ++s)
            seeds.push_back(static_cast<std::uint64_t>(s));
        return seeds;
    }
    std::vector<double> list;
    try {
        list = root.require<std::vector<double>>("seeds");
    } catch (const SetupError&) {
        root.fail("seeds", "must be a count N (seeds 1..N) or an array of integers");
    }
    if (list.empty()) root.fail("seeds", "must not be empty");
    for (const double v : list) {
        if (!(v >= 0.0 && v <= 9007199254740992.0 && v == std::floor(v))) {
            root.fail("seeds", "each seed must be a whole number in [0, 2^53]");
        }
        seeds.push_back(static_cast<std::uint64_t>(v));
    }
    return seeds;
}

// [set]: each key an axis; a sub-table (video.offset_dc = [...], or [set.video]) gives the
// preset's dotted keys.
void readSetAxes(const ConfigTable& t, const std::string& prefix, SweepSpec& spec) {
    for (const std::string& key : keysInFileOrder(t)) {
        std::optional<ConfigTable> sub;
        try {
            sub = t.optionalTable(key);
        } catch (const SetupError&) {  // not a table: an axis
        }
        if (sub) {
            readSetAxes(*sub, prefix + key + ".", spec);
            continue;
        }
        if (!identifier(key)) t.fail(key, "a key must be a name such as gain_V or video.offset_dc");
        if (reservedColumn(prefix + key))
            t.fail(key, "is a column of the results: not a [set] key");
        spec.sets.emplace_back(prefix + key, textValues(t, key));
    }
}

void readCommand(const ConfigTable& root, SweepSpec& spec) {
    const ConfigTable cmd = root.table("command");
    spec.argv = cmd.require<std::vector<std::string>>("argv");
    if (spec.argv.empty()) cmd.fail("argv", "must name a program");
    spec.concat = cmd.get<std::string>("concat", "");
    if (!spec.concat.empty() &&
        (spec.concat.find('/') != std::string::npos || spec.concat == "." || spec.concat == "..")) {
        cmd.fail("concat", "must be a file name, without a folder");
    }
    spec.concatHeaderLines = cmd.get<int>("concat_header_lines", 0);
    if (spec.concatHeaderLines < 0 || spec.concatHeaderLines > 1000) {
        cmd.fail("concat_header_lines", "must be in 0..1000");
    }
}

void readVars(const ConfigTable& root, const std::vector<std::string>& given, SweepSpec& spec) {
    if (const auto vars = root.optionalTable("vars")) {
        for (const std::string& key : vars->keys()) {
            if (!identifier(key)) vars->fail(key, "a name must be a C identifier");
            std::string value;
            try {
                value = vars->require<std::string>(key);
            } catch (const SetupError&) {
                value = jsonNumber(vars->require<double>(key));
            }
            spec.vars[key] = value;
        }
    }
    for (const std::string& nv : given) {
        const auto eq = nv.find('=');
        if (eq == std::string::npos || !identifier(nv.substr(0, eq))) {
            throw SetupError("--var " + nv + ": must be NAME=VALUE");
        }
        spec.vars[nv.substr(0, eq)] = nv.substr(eq + 1);
    }
}

}  // namespace

SweepSpec loadSpec(const fs::path& file, const fs::path& scenariosDir,
                   const std::vector<std::string>& vars) {
    SweepSpec spec;
    spec.file = fs::absolute(file).lexically_normal();
    const ConfigDocument doc = ConfigDocument::parseFile(spec.file);
    const ConfigTable root = doc.root();
    const fs::path base = spec.file.parent_path();
    spec.name = root.require<std::string>("name");
    if (!plainName(spec.name)) root.fail("name", "must be 1..64 of [A-Za-z0-9_.-]");
    const std::string kind = root.get<std::string>("kind", "run");
    if (kind != "run" && kind != "command") root.fail("kind", "must be \"run\" or \"command\"");
    spec.kind = kind == "run" ? JobKind::Run : JobKind::Command;

    if (root.contains("scenarios") || spec.kind == JobKind::Run) {
        spec.scenarios = textValues(root, "scenarios");
        for (const std::string& s : spec.scenarios) {
            if (spec.kind == JobKind::Command) {  // a command's values, as written
                spec.scenarioPaths.push_back(s);
                continue;
            }
            // A name as `nvstim run` takes it: NAME/ holding scenario.toml, or NAME.toml.
            std::error_code ec;
            fs::path p = pathLike(s) ? base / s : scenariosDir / s;
            if (!pathLike(s) && !fs::is_regular_file(p / "scenario.toml", ec))
                p = scenariosDir / (s + ".toml");
            if (!fs::exists(p, ec)) {
                root.fail("scenarios",
                          "no scenario " + p.string() +
                              (pathLike(s) ? "" : " (a name of the shipped scenarios)"));
            }
            spec.scenarioPaths.push_back(fs::absolute(p).lexically_normal().string());
        }
    }
    if (root.contains("presets")) {
        spec.presets = textValues(root, "presets");
        for (const std::string& p : spec.presets)
            spec.presetArgs.push_back(pathLike(p) ? (base / p).lexically_normal().string() : p);
    }
    spec.seeds = readSeeds(root);
    if (const auto set = root.optionalTable("set")) readSetAxes(*set, "", spec);
    spec.timeout_s = root.get<double>("timeout_s", spec.timeout_s);
    if (!(spec.timeout_s > 0.0 && spec.timeout_s <= 1e7))
        root.fail("timeout_s", "must be in (0, 1e7]");
    if (spec.kind == JobKind::Run) {
        spec.frames = root.require<std::int64_t>("frames");
        if (spec.frames < 1 || spec.frames > 100000000) root.fail("frames", "must be in 1..1e8");
        spec.keepFrames = root.get<bool>("keep_frames", false);
        spec.runArgs = root.get<std::vector<std::string>>("run_args", {});
        for (const std::string& a : spec.runArgs) {
            for (const char* owned :
                 {"--frames", "--clock", "--camera", "--set", "--output", "--stats"})
                if (a.rfind(owned, 0) == 0) root.fail("run_args", a + " is the sweep's own");
        }
    } else {
        readCommand(root, spec);
    }
    readVars(root, vars, spec);
    doc.finish();
    return spec;
}

std::string expandPlaceholders(const std::string& text,
                               const std::map<std::string, std::string>& values,
                               const std::string& what) {
    std::string out;
    for (std::size_t i = 0; i < text.size(); ++i) {
        const char c = text[i];
        if ((c == '{' || c == '}') && i + 1 < text.size() && text[i + 1] == c) {
            out += c;
            ++i;
            continue;
        }
        if (c == '}') throw SetupError(what + ": a lone '}' in \"" + text + "\" (write }})");
        if (c != '{') {
            out += c;
            continue;
        }
        const auto close = text.find('}', i);
        if (close == std::string::npos) {
            throw SetupError(what + ": an unclosed '{' in \"" + text + "\" (write {{)");
        }
        const std::string name = text.substr(i + 1, close - i - 1);
        const auto it = values.find(name);
        if (it == values.end()) {
            std::string known;
            for (const auto& [k, v] : values)
                known += (known.empty() ? "" : ", ") + k;
            throw SetupError(what + ": unknown placeholder {" + name + "} (known: " + known + ")");
        }
        out += it->second;
        i = close;
    }
    return out;
}

}  // namespace nvs::rt::sweep
