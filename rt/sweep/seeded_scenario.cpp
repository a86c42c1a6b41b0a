#include "rt/sweep/seeded_scenario.h"

#include <toml++/toml.h>

#include <fstream>
#include <sstream>
#include <string>

#include "sim/core/error.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

namespace {

// A relative path string of `table.key`, made absolute against the scenario's folder.
void absolutePath(toml::table* table, const char* key, const fs::path& base) {
    if (table == nullptr) return;
    toml::node* n = table->get(key);
    if (n == nullptr || !n->is_string()) return;
    const fs::path p = n->value_exact<std::string>().value_or("");
    if (p.is_relative()) *n->as_string() = (base / p).lexically_normal().string();
}

// [telemetry] source = "replay:LOG[?...]": LOG as rt/compose/scenario.cpp's readTelemetry
// resolves it.
void absoluteReplay(toml::table* telemetry, const fs::path& base) {
    if (telemetry == nullptr) return;
    toml::node* n = telemetry->get("source");
    if (n == nullptr || !n->is_string()) return;
    const std::string spec = n->value_exact<std::string>().value_or("");
    if (spec.rfind("replay:", 0) != 0) return;
    const auto q = spec.find('?');
    const std::string log = spec.substr(7, q == std::string::npos ? q : q - 7);
    if (fs::path(log).is_relative()) {
        *n->as_string() = "replay:" + (base / log).lexically_normal().string() +
                          (q == std::string::npos ? "" : spec.substr(q));
    }
}

// The seed as TOML's 64-bit signed integer (the scenario's reader takes ≥ 0).
toml::int64_t tomlSeed(std::uint64_t seed, const fs::path& file) {
    if (seed > static_cast<std::uint64_t>(INT64_MAX)) {
        throw SetupError(file.string() + ": seed " + std::to_string(seed) +
                         " does not fit a TOML integer");
    }
    return static_cast<toml::int64_t>(seed);
}

}  // namespace

void writeSeededScenario(const fs::path& from, std::uint64_t seed, const fs::path& to) {
    std::error_code ec;
    const fs::path file = fs::is_directory(from, ec) ? from / "scenario.toml" : from;
    const fs::path base = fs::absolute(file).parent_path();
    std::ifstream in(file, std::ios::binary);
    if (!in) throw SetupError("scenario '" + file.string() + "': cannot read");
    std::ostringstream text;
    text << in.rdbuf();
    toml::table doc;
    try {
        doc = toml::parse(text.str(), file.string());
    } catch (const toml::parse_error& e) {
        throw SetupError(FileLoc{file.string(), static_cast<int>(e.source().begin.line),
                                 static_cast<int>(e.source().begin.column)},
                         std::string(e.description()));
    }
    toml::table* scenario = doc["scenario"].as_table();
    if (scenario == nullptr) throw SetupError(file.string() + ": no [scenario] table");
    scenario->insert_or_assign("seed", tomlSeed(seed, file));
    if (toml::table* camera = doc["camera"].as_table();
        camera != nullptr && camera->contains("seed"))
        camera->insert_or_assign("seed", tomlSeed(seed, file));
    if (toml::array* channels = doc["channel"].as_array(); channels != nullptr) {
        for (std::size_t i = 0; i < channels->size(); ++i) {
            toml::table* ch = channels->get(i)->as_table();
            if (ch != nullptr && ch->contains("seed"))
                ch->insert_or_assign("seed", tomlSeed(seed + i, file));
        }
    }
    absolutePath(doc["scene"].as_table(), "file", base);
    absolutePath(doc["thermal"].as_table(), "weather", base);
    absolutePath(doc["thermal"].as_table(), "materials", base);
    absoluteReplay(doc["telemetry"].as_table(), base);

    std::ofstream out(to, std::ios::binary | std::ios::trunc);
    out << "# " << file.string() << " with seed = " << seed
        << " and its relative paths made absolute (nvstim sweep)\n"
        << doc << "\n";
    out.close();
    if (!out) throw SetupError(to.string() + ": cannot write the seeded scenario");
}

}  // namespace nvs::rt::sweep
