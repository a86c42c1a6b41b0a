#pragma once
// Reading a thermal camera preset (config/thermal_cameras/NAME.toml) with strict keys and
// `--set KEY=VALUE` overrides: each stage's Params reads its own tables through a Reader
// (sim/bolometer/stages/*.h); loadThermalCamera (sim/bolometer/camera.h) runs them in turn.
// The same contract as the intensified camera's reader (sim/sensor/preset_reader.h), kept
// apart so that this library depends on sim/core alone.

#include <cmath>
#include <map>
#include <optional>
#include <set>
#include <string>

#include "sim/core/config.h"
#include "sim/core/error.h"

namespace nvs::bolometer {

// KEY=VALUE overrides from the command line. Keys are dotted preset paths ("noise.netd_K").
using Overrides = std::map<std::string, std::string>;

class Reader {
  public:
    Reader(std::optional<ConfigTable> table, std::string prefix, const Overrides* ov,
           std::set<std::string>* used, FileLoc loc)
        : t_(std::move(table)),
          prefix_(std::move(prefix)),
          ov_(ov),
          used_(used),
          loc_(std::move(loc)) {}

    // A preset may leave out a whole table: its parameters keep their defaults.
    Reader sub(const std::string& key) const {
        std::optional<ConfigTable> t = t_ ? t_->optionalTable(key) : std::nullopt;
        return Reader(std::move(t), prefix_ + key + ".", ov_, used_, loc_);
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

    // Throws SetupError at the key's place in the file (file:line:col), or naming --set KEY.
    [[noreturn]] void fail(const std::string& key, const std::string& msg) const {
        const std::string full = prefix_ + key;
        if (ov_->count(full) != 0) throw SetupError("--set " + full + ": " + msg);
        if (t_ && t_->contains(key)) t_->fail(key, msg);
        throw SetupError(loc_, "key '" + full + "': " + msg);
    }

  private:
    template <typename T>
    static T parse(const std::string& key, const std::string& text) {
        // The value is parsed as TOML so that types behave as in the file; bare words are
        // strings (--set agc.mode=linear).
        ConfigDocument d = [&] {
            try {
                return ConfigDocument::parseString("v = " + text + "\n", "--set " + key);
            } catch (const SetupError&) {
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
    const Overrides* ov_;
    std::set<std::string>* used_;
    FileLoc loc_;
};

inline void require(bool ok, const Reader& r, const std::string& key, const std::string& msg) {
    if (!ok) r.fail(key, msg);
}
inline double positive(const Reader& r, const std::string& key, double def) {
    const double v = r.get<double>(key, def);
    require(std::isfinite(v) && v > 0.0, r, key, "must be > 0");
    return v;
}
inline double nonNegative(const Reader& r, const std::string& key, double def) {
    const double v = r.get<double>(key, def);
    require(std::isfinite(v) && v >= 0.0, r, key, "must be >= 0");
    return v;
}
// A value in [0, hi).
inline double fractionBelow(const Reader& r, const std::string& key, double def, double hi) {
    const double v = r.get<double>(key, def);
    require(std::isfinite(v) && v >= 0.0 && v < hi, r, key,
            "must be in [0, " + std::to_string(hi) + ")");
    return v;
}

}  // namespace nvs::bolometer
