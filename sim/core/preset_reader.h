#pragma once
// Reading a preset (the intensified camera's, config/cameras/NAME.toml; the thermal camera's,
// config/thermal_cameras/NAME.toml) with strict keys and `--set KEY=VALUE` overrides: each
// stage's Params reads its own tables through a PresetReader (sim/sensor/stages/*.h,
// sim/bolometer/stages/*.h); loadCamera and loadThermalCamera run them in turn.

#include <cmath>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <string>

#include "sim/core/config.h"
#include "sim/core/error.h"

namespace nvs {

// KEY=VALUE overrides from the command line; keys are dotted preset paths ("mcp.gain_max").
using PresetOverrides = std::map<std::string, std::string>;

// Reads a preset table with `--set` overrides taking precedence. Every override must name a
// parameter that the code reads; unused overrides are reported by finish().
class PresetReader {
  public:
    PresetReader(std::optional<ConfigTable> table, std::string prefix, const PresetOverrides* ov,
                 std::set<std::string>* used, FileLoc loc, std::filesystem::path baseDir = {})
        : t_(std::move(table)),
          prefix_(std::move(prefix)),
          ov_(ov),
          used_(used),
          loc_(std::move(loc)),
          baseDir_(std::move(baseDir)) {}

    // A preset may leave out a whole table: its parameters keep their defaults.
    PresetReader sub(const std::string& key) const {
        std::optional<ConfigTable> t = t_ ? t_->optionalTable(key) : std::nullopt;
        return PresetReader(std::move(t), prefix_ + key + ".", ov_, used_, loc_, baseDir_);
    }

    template <typename T>
    T get(const std::string& key, const T& def) const {
        const T fromFile = t_ ? t_->get<T>(key, def) : def;  // marks the key read
        const std::string full = prefix_ + key;
        const auto it = ov_->find(full);
        if (it == ov_->end()) return fromFile;
        used_->insert(full);
        return parse<T>(full, it->second);
    }

    // Whether the preset file gives the key, and whether an override does.
    bool inFile(const std::string& key) const { return t_ && t_->contains(key); }
    bool overridden(const std::string& key) const { return ov_->count(prefix_ + key) != 0; }

    // Where the preset came from, and the folder its data files are relative to.
    const FileLoc& loc() const { return loc_; }
    const std::filesystem::path& baseDir() const { return baseDir_; }

    [[noreturn]] void fail(const std::string& key, const std::string& msg) const {
        const std::string full = prefix_ + key;
        if (ov_->count(full) != 0) throw SetupError("--set " + full + ": " + msg);
        if (t_) t_->fail(key, msg);
        throw SetupError(loc_, "key '" + full + "': " + msg);
    }

  private:
    template <typename T>
    static T parse(const std::string& key, const std::string& text) {
        // The value is parsed as TOML so that types behave as in the file.
        const std::string doc = "v = " + text + "\n";
        ConfigDocument d = [&] {
            try {
                return ConfigDocument::parseString(doc, "--set " + key);
            } catch (const SetupError&) {
                // Bare words are strings: --set agc=agc
                return ConfigDocument::parseString("v = \"" + text + "\"\n", "--set " + key);
            }
        }();
        try {
            return d.root().require<T>("v");
        } catch (const SetupError& e) {
            throw SetupError("--set " + key + "=" + text + ": " + e.what());
        }
    }

    std::optional<ConfigTable> t_;
    std::string prefix_;
    const PresetOverrides* ov_;
    std::set<std::string>* used_;
    FileLoc loc_;
    std::filesystem::path baseDir_;
};

inline void require(bool ok, const PresetReader& r, const std::string& key,
                    const std::string& msg) {
    if (!ok) r.fail(key, msg);
}

inline double positive(const PresetReader& r, const std::string& key, double def) {
    const double v = r.get<double>(key, def);
    require(std::isfinite(v) && v > 0.0, r, key, "must be > 0");
    return v;
}
inline double nonNegative(const PresetReader& r, const std::string& key, double def) {
    const double v = r.get<double>(key, def);
    require(std::isfinite(v) && v >= 0.0, r, key, "must be >= 0");
    return v;
}

// A value in [0, hi).
inline double fractionBelow(const PresetReader& r, const std::string& key, double def, double hi) {
    const double v = r.get<double>(key, def);
    require(std::isfinite(v) && v >= 0.0 && v < hi, r, key,
            "must be in [0, " + std::to_string(hi) + ")");
    return v;
}

}  // namespace nvs
