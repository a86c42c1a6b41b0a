// nvstim list presets|cameras|scenarios [--json]: what this nvstim ships, from its data folders
// (rt/cli/data_dirs.h), one line each, sorted by name.
//
//   presets (cameras is the same list)  CONFIG/cameras/*.toml (kind "intensified") and
//           CONFIG/thermal_cameras/*.toml (kind "thermal"): the name --camera takes (the file's
//           stem) and a description: the preset's `description` key where it has one, else the
//           first line of the comment that opens the file
//   scenarios  SCENARIOS/NAME/scenario.toml: the name run, render and replay take (the folder's),
//           its [scenario] description and group
//
// Text: NAME, (presets) KIND, then the description, in aligned columns. --json: one object per
// line, {"name","kind","description","path"} or {"name","group","description","path"}.
// A file that cannot be read as TOML is listed with its error as the description: the listing
// shows what is there rather than stopping at the first broken file.

#include <algorithm>
#include <cctype>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/run/run.h"
#include "sim/core/config.h"
#include "sim/core/error.h"

namespace nvs::cli {

namespace {
namespace fs = std::filesystem;

struct Entry {
    std::string name, kind, description;  // kind: a preset's kind, or a scenario's group
    fs::path path;
};

// The first sentence of the comment block that opens a file, its lines joined: up to the first
// ':' that ends a clause, or the first '.' that ends the text or is followed by a capital.
std::string openingComment(const fs::path& file) {
    std::ifstream in(file);
    std::string line, text;
    while (std::getline(in, line)) {
        const auto start = line.find_first_not_of(" \t");
        if (start == std::string::npos || line[start] != '#') break;
        const auto from = line.find_first_not_of("# \t", start);
        if (from == std::string::npos) continue;
        auto to = line.find_last_not_of(" \t\r");
        text += (text.empty() ? "" : " ") + line.substr(from, to + 1 - from);
    }
    for (std::size_t i = 0; i < text.size(); ++i) {
        const bool end = i + 1 == text.size();
        const bool clause = text[i] == ':' && (end || text[i + 1] == ' ');
        const bool sentence =
            text[i] == '.' && (end || (text[i + 1] == ' ' && i + 2 < text.size() &&
                                       std::isupper(static_cast<unsigned char>(text[i + 2])) != 0));
        if (clause || sentence) return text.substr(0, i);
    }
    return text;
}

// A table's string key, or "" where it is absent or the file does not parse (then the error).
std::string stringKey(const ConfigTable& t, const char* key) {
    return t.get<std::string>(key, "");
}

std::vector<Entry> presets(const fs::path& config) {
    std::vector<Entry> out;
    for (const auto& [folder, kind] :
         {std::pair{"cameras", "intensified"}, std::pair{"thermal_cameras", "thermal"}}) {
        std::error_code ec;
        for (fs::directory_iterator it(config / folder, ec), end; !ec && it != end;
             it.increment(ec)) {
            if (it->path().extension() != ".toml") continue;
            Entry e{it->path().stem().string(), kind, "", it->path()};
            try {
                e.description = stringKey(ConfigDocument::parseFile(e.path).root(), "description");
            } catch (const SetupError& err) {
                e.description = err.what();
            }
            if (e.description.empty()) e.description = openingComment(e.path);
            out.push_back(e);
        }
    }
    return out;
}

std::vector<Entry> scenarios(const fs::path& dir) {
    std::vector<Entry> out;
    for (const std::string& name : scenarioNames(dir)) {
        Entry e{name, "", "", dir / name};
        try {
            const ConfigDocument doc = ConfigDocument::parseFile(e.path / "scenario.toml");
            const ConfigTable s = doc.root().table("scenario");
            e.description = stringKey(s, "description");
            e.kind = stringKey(s, "group");
        } catch (const SetupError& err) {
            e.description = err.what();
        }
        out.push_back(e);
    }
    return out;
}

}  // namespace

int runList(const ListOptions& opts) {
    const DataDirs dirs = resolveDataDirs();
    const bool isScenarios = opts.what == "scenarios";
    const fs::path from = isScenarios ? scenariosDir(dirs) : dirs.config;
    std::vector<Entry> entries = isScenarios ? scenarios(from) : presets(from);
    if (entries.empty()) {
        throw SetupError("list " + opts.what + ": none found in " + from.string());
    }
    std::sort(entries.begin(), entries.end(),
              [](const Entry& a, const Entry& b) { return a.name < b.name; });
    std::size_t nameW = 0, kindW = 0;
    for (const Entry& e : entries) {
        nameW = std::max(nameW, e.name.size());
        kindW = std::max(kindW, e.kind.size());
    }
    for (const Entry& e : entries) {
        if (opts.json) {
            std::printf("{\"name\":\"%s\",\"%s\":\"%s\",\"description\":\"%s\",\"path\":\"%s\"}\n",
                        rt::jsonEscape(e.name).c_str(), isScenarios ? "group" : "kind",
                        rt::jsonEscape(e.kind).c_str(), rt::jsonEscape(e.description).c_str(),
                        rt::jsonEscape(e.path.string()).c_str());
        } else if (isScenarios) {
            std::printf("%-*s  %s\n", static_cast<int>(nameW), e.name.c_str(),
                        e.description.c_str());
        } else {
            std::printf("%-*s  %-*s  %s\n", static_cast<int>(nameW), e.name.c_str(),
                        static_cast<int>(kindW), e.kind.c_str(), e.description.c_str());
        }
    }
    return kExitOk;
}

}  // namespace nvs::cli
