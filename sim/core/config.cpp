#include "sim/core/config.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

#include "sim/core/input_file.h"

namespace nvs {

struct ConfigState {
    std::string file;
    toml::table root;
    std::unordered_set<const toml::node*> used;
    // Every key name the code asked for, per table, present or not: candidates for
    // "did you mean".
    std::unordered_map<const toml::table*, std::set<std::string, std::less<>>> asked;
};

namespace {

FileLoc locOf(const ConfigState& s, const toml::node& n) {
    const auto& src = n.source();
    return FileLoc{s.file, static_cast<int>(src.begin.line), static_cast<int>(src.begin.column)};
}

const char* typeName(const toml::node& n) {
    switch (n.type()) {
        case toml::node_type::string:
            return "a string";
        case toml::node_type::integer:
            return "an integer";
        case toml::node_type::floating_point:
            return "a floating-point number";
        case toml::node_type::boolean:
            return "a boolean";
        case toml::node_type::table:
            return "a table";
        case toml::node_type::array:
            return "an array";
        case toml::node_type::date:
            return "a date";
        case toml::node_type::time:
            return "a time";
        case toml::node_type::date_time:
            return "a date-time";
        default:
            return "nothing";
    }
}

template <typename T>
struct Convert;

template <>
struct Convert<bool> {
    static constexpr const char* kWant = "a boolean";
    static std::optional<bool> from(const toml::node& n) { return n.value_exact<bool>(); }
};
template <>
struct Convert<std::int64_t> {
    static constexpr const char* kWant = "an integer";
    static std::optional<std::int64_t> from(const toml::node& n) {
        return n.value_exact<std::int64_t>();
    }
};
template <>
struct Convert<int> {
    static constexpr const char* kWant = "an integer (32-bit)";
    static std::optional<int> from(const toml::node& n) {
        const auto v = n.value_exact<std::int64_t>();
        if (!v || *v < std::numeric_limits<int>::min() || *v > std::numeric_limits<int>::max()) {
            return std::nullopt;
        }
        return static_cast<int>(*v);
    }
};
template <>
struct Convert<double> {
    static constexpr const char* kWant = "a number";
    static std::optional<double> from(const toml::node& n) {
        if (const auto d = n.value_exact<double>()) return *d;
        if (const auto i = n.value_exact<std::int64_t>()) return static_cast<double>(*i);
        return std::nullopt;
    }
};
template <>
struct Convert<std::string> {
    static constexpr const char* kWant = "a string";
    static std::optional<std::string> from(const toml::node& n) {
        return n.value_exact<std::string>();
    }
};
template <typename E>
struct Convert<std::vector<E>> {
    static std::string want() { return std::string("an array of ") + Convert<E>::kWant + "s"; }
    static std::optional<std::vector<E>> from(const toml::node& n) {
        const toml::array* arr = n.as_array();
        if (arr == nullptr) return std::nullopt;
        std::vector<E> out;
        for (const auto& el : *arr) {
            const auto v = Convert<E>::from(el);
            if (!v) return std::nullopt;
            out.push_back(*v);
        }
        return out;
    }
};

template <typename T>
std::string wantOf() {
    if constexpr (requires { Convert<T>::kWant; }) {
        return Convert<T>::kWant;
    } else {
        return Convert<T>::want();
    }
}

// Depth-first, file-ordered walk collecting unused keys.
void collectUnused(const ConfigState& s, const toml::table& t, const std::string& prefix,
                   std::vector<std::pair<FileLoc, std::string>>* out,
                   std::vector<std::string>* suggestions) {
    for (const auto& [k, v] : t) {
        const std::string name =
            prefix.empty() ? std::string(k.str()) : prefix + "." + std::string(k.str());
        if (!s.used.count(&v)) {
            std::string hint;
            if (const auto it = s.asked.find(&t); it != s.asked.end()) {
                std::size_t best = std::numeric_limits<std::size_t>::max();
                for (const auto& cand : it->second) {
                    if (t.contains(cand)) continue;
                    const std::size_t d = editDistance(k.str(), cand);
                    if (d < best && d <= std::max<std::size_t>(2, cand.size() / 3)) {
                        best = d;
                        hint = cand;
                    }
                }
            }
            const auto& ks = k.source();
            out->emplace_back(
                FileLoc{s.file, static_cast<int>(ks.begin.line), static_cast<int>(ks.begin.column)},
                name);
            suggestions->push_back(hint);
            continue;
        }
        if (const auto* sub = v.as_table()) {
            collectUnused(s, *sub, name, out, suggestions);
        } else if (const auto* arr = v.as_array()) {
            std::size_t i = 0;
            for (const auto& el : *arr) {
                if (const auto* st = el.as_table()) {
                    collectUnused(s, *st, name + "[" + std::to_string(i) + "]", out, suggestions);
                }
                ++i;
            }
        }
    }
}

}  // namespace

std::size_t editDistance(std::string_view a, std::string_view b) {
    std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
    for (std::size_t j = 0; j <= b.size(); ++j)
        prev[j] = j;
    for (std::size_t i = 1; i <= a.size(); ++i) {
        cur[0] = i;
        for (std::size_t j = 1; j <= b.size(); ++j) {
            const std::size_t sub = prev[j - 1] + (a[i - 1] == b[j - 1] ? 0 : 1);
            cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, sub});
        }
        std::swap(prev, cur);
    }
    return prev[b.size()];
}

// ---- ConfigTable -------------------------------------------------------------------------

std::string ConfigTable::qualified(std::string_view key) const {
    return path_.empty() ? std::string(key) : path_ + "." + std::string(key);
}

const toml::node* ConfigTable::lookup(std::string_view key) const {
    if (table_ == nullptr) return nullptr;
    state_->asked[table_].emplace(key);
    const toml::node* n = table_->get(key);
    if (n != nullptr) state_->used.insert(n);
    return n;
}

FileLoc ConfigTable::location() const {
    return loc_;
}

FileLoc ConfigTable::location(std::string_view key) const {
    if (table_ != nullptr) {
        if (const toml::node* n = table_->get(key)) return locOf(*state_, *n);
    }
    return loc_;
}

void ConfigTable::fail(std::string_view key, const std::string& message) const {
    throw SetupError(location(key), "key '" + qualified(key) + "': " + message);
}

bool ConfigTable::contains(std::string_view key) const {
    return table_ != nullptr && table_->contains(key);
}

template <typename T>
std::optional<T> ConfigTable::optional(std::string_view key) const {
    const toml::node* n = lookup(key);
    if (n == nullptr) return std::nullopt;
    auto v = Convert<T>::from(*n);
    if (!v) {
        fail(key, "must be " + wantOf<T>() + ", found " + typeName(*n));
    }
    if constexpr (std::is_same_v<T, double>) {
        if (!std::isfinite(*v)) fail(key, "must be finite");
    }
    return v;
}

template <typename T>
T ConfigTable::get(std::string_view key, const T& defaultValue) const {
    auto v = optional<T>(key);
    return v ? *v : defaultValue;
}

template <typename T>
T ConfigTable::require(std::string_view key) const {
    auto v = optional<T>(key);
    if (!v) {
        throw SetupError(loc_,
                         "missing required key '" + qualified(key) + "' (" + wantOf<T>() + ")");
    }
    return *v;
}

std::optional<ConfigTable> ConfigTable::optionalTable(std::string_view key) const {
    const toml::node* n = lookup(key);
    if (n == nullptr) return std::nullopt;
    const toml::table* t = n->as_table();
    if (t == nullptr) fail(key, std::string("must be a table, found ") + typeName(*n));
    return ConfigTable(state_, t, qualified(key), locOf(*state_, *n));
}

ConfigTable ConfigTable::table(std::string_view key) const {
    if (auto t = optionalTable(key)) return *t;
    throw SetupError(loc_, "missing required table [" + qualified(key) + "]");
}

std::vector<ConfigTable> ConfigTable::tableArray(std::string_view key) const {
    std::vector<ConfigTable> out;
    const toml::node* n = lookup(key);
    if (n == nullptr) return out;
    const toml::array* arr = n->as_array();
    if (arr == nullptr) fail(key, std::string("must be an array of tables, found ") + typeName(*n));
    std::size_t i = 0;
    for (const auto& el : *arr) {
        const toml::table* t = el.as_table();
        if (t == nullptr) {
            throw SetupError(locOf(*state_, el), "key '" + qualified(key) + "[" +
                                                     std::to_string(i) + "]': must be a table");
        }
        state_->used.insert(&el);
        out.push_back(ConfigTable(state_, t, qualified(key) + "[" + std::to_string(i) + "]",
                                  locOf(*state_, el)));
        ++i;
    }
    return out;
}

namespace {
void markSubtreeUsed(ConfigState& s, const toml::node& n) {
    s.used.insert(&n);
    if (const auto* t = n.as_table()) {
        for (const auto& [k, v] : *t)
            markSubtreeUsed(s, v);
    } else if (const auto* arr = n.as_array()) {
        for (const auto& el : *arr)
            markSubtreeUsed(s, el);
    }
}
}  // namespace

void ConfigTable::skip(std::string_view key) const {
    if (table_ == nullptr) return;
    if (const toml::node* n = table_->get(key)) markSubtreeUsed(*state_, *n);
}

std::vector<std::string> ConfigTable::keys() const {
    std::vector<std::string> out;
    if (table_ == nullptr) return out;
    for (const auto& [k, v] : *table_)
        out.emplace_back(k.str());
    return out;
}

template bool ConfigTable::get<bool>(std::string_view, const bool&) const;
template int ConfigTable::get<int>(std::string_view, const int&) const;
template std::int64_t ConfigTable::get<std::int64_t>(std::string_view, const std::int64_t&) const;
template double ConfigTable::get<double>(std::string_view, const double&) const;
template std::string ConfigTable::get<std::string>(std::string_view, const std::string&) const;
template std::vector<double> ConfigTable::get<std::vector<double>>(
    std::string_view, const std::vector<double>&) const;
template std::vector<std::string> ConfigTable::get<std::vector<std::string>>(
    std::string_view, const std::vector<std::string>&) const;
template bool ConfigTable::require<bool>(std::string_view) const;
template int ConfigTable::require<int>(std::string_view) const;
template std::int64_t ConfigTable::require<std::int64_t>(std::string_view) const;
template double ConfigTable::require<double>(std::string_view) const;
template std::string ConfigTable::require<std::string>(std::string_view) const;
template std::vector<double> ConfigTable::require<std::vector<double>>(std::string_view) const;
template std::vector<std::string> ConfigTable::require<std::vector<std::string>>(
    std::string_view) const;
template std::optional<bool> ConfigTable::optional<bool>(std::string_view) const;
template std::optional<int> ConfigTable::optional<int>(std::string_view) const;
template std::optional<std::int64_t> ConfigTable::optional<std::int64_t>(std::string_view) const;
template std::optional<double> ConfigTable::optional<double>(std::string_view) const;
template std::optional<std::string> ConfigTable::optional<std::string>(std::string_view) const;
template std::optional<std::vector<double>> ConfigTable::optional<std::vector<double>>(
    std::string_view) const;
template std::optional<std::vector<std::string>> ConfigTable::optional<std::vector<std::string>>(
    std::string_view) const;

// ---- ConfigDocument ----------------------------------------------------------------------

ConfigDocument ConfigDocument::parseString(std::string_view text, const std::string& name) {
    ConfigDocument d;
    d.state_ = std::make_shared<ConfigState>();
    d.state_->file = name;
    try {
        d.state_->root = toml::parse(text, name);
    } catch (const toml::parse_error& e) {
        const auto& b = e.source().begin;
        throw SetupError(FileLoc{name, static_cast<int>(b.line), static_cast<int>(b.column)},
                         std::string("TOML syntax: ") + std::string(e.description()));
    }
    return d;
}

ConfigDocument ConfigDocument::parseFile(const std::filesystem::path& path) {
    return parseString(readInputFile(path, kMaxConfigFileBytes, "configuration file"),
                       path.string());
}

ConfigTable ConfigDocument::root() const {
    return ConfigTable(state_, &state_->root, "", FileLoc{state_->file, 1, 1});
}

void ConfigDocument::finish() const {
    std::vector<std::pair<FileLoc, std::string>> unused;
    std::vector<std::string> hints;
    collectUnused(*state_, state_->root, "", &unused, &hints);
    if (unused.empty()) return;
    std::string msg = "unknown key '" + unused.front().second + "'";
    if (!hints.front().empty()) msg += " (did you mean '" + hints.front() + "'?)";
    if (unused.size() > 1) {
        msg += " and " + std::to_string(unused.size() - 1) + " more unknown key" +
               (unused.size() > 2 ? "s" : "") + " (";
        for (std::size_t i = 1; i < unused.size() && i < 4; ++i) {
            if (i > 1) msg += ", ";
            msg += "'" + unused[i].second + "' at line " + std::to_string(unused[i].first.line);
        }
        msg += unused.size() > 4 ? ", ...)" : ")";
    }
    throw SetupError(unused.front().first, msg);
}

}  // namespace nvs
