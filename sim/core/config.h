#pragma once
// Strict configuration (docs/style.md §9): defaults live in code, and every key a file holds must
// be read by the code. After reading, finish() reports the first key nobody asked for, with its
// file:line:column and, when the code asked for a similar name, "did you mean". Wrong types
// and out-of-range values are errors at the value's place. Errors are SetupError.
//
// Usage (setup phase only):
//   ConfigDocument doc = ConfigDocument::parseFile("camera.toml");
//   ConfigTable root = doc.root();
//   double f = root.get<double>("f_number", 5.6);
//   ConfigTable mcp = root.table("mcp");
//   ...
//   doc.finish();   // throws on unknown/unused keys

#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include "sim/core/error.h"

namespace toml {
inline namespace v3 {
class table;
class node;
}  // namespace v3
}  // namespace toml

namespace nvs {

struct ConfigState;  // shared by a document and its tables

class ConfigTable {
  public:
    // Scalars: bool, int, std::int64_t, double (integers accepted), std::string.
    // Arrays: std::vector<double>, std::vector<std::string>.
    template <typename T>
    T get(std::string_view key, const T& defaultValue) const;
    template <typename T>
    T require(std::string_view key) const;
    template <typename T>
    std::optional<T> optional(std::string_view key) const;

    bool contains(std::string_view key) const;
    // A sub-table; `require`d or empty if absent.
    ConfigTable table(std::string_view key) const;
    std::optional<ConfigTable> optionalTable(std::string_view key) const;
    // An array of tables ([[key]]); empty if absent.
    std::vector<ConfigTable> tableArray(std::string_view key) const;
    // Every key of this table, in file order (marks none as used).
    std::vector<std::string> keys() const;
    // Marks a key, and everything under it, as read without reading it: for a table that
    // another component owns and checks itself. Absent keys are ignored.
    void skip(std::string_view key) const;

    // Where this table, or one of its keys, is in the file.
    FileLoc location() const;
    FileLoc location(std::string_view key) const;
    // Dotted path of this table from the root ("" for the root).
    const std::string& path() const { return path_; }

    // Throws SetupError at the key's place: "file:l:c: key 'a.b': <message>".
    [[noreturn]] void fail(std::string_view key, const std::string& message) const;

  private:
    friend class ConfigDocument;
    ConfigTable(std::shared_ptr<ConfigState> state, const toml::table* table, std::string path,
                FileLoc loc)
        : state_(std::move(state)), table_(table), path_(std::move(path)), loc_(std::move(loc)) {}
    const toml::node* lookup(std::string_view key) const;
    std::string qualified(std::string_view key) const;

    std::shared_ptr<ConfigState> state_;
    const toml::table* table_ = nullptr;  // null for an absent optional table
    std::string path_;
    FileLoc loc_;
};

class ConfigDocument {
  public:
    static ConfigDocument parseFile(const std::filesystem::path& path);
    static ConfigDocument parseString(std::string_view text, const std::string& name);

    ConfigTable root() const;
    // Throws SetupError naming the first key that was never read (in file order).
    void finish() const;

  private:
    std::shared_ptr<ConfigState> state_;
};

extern template bool ConfigTable::get<bool>(std::string_view, const bool&) const;
extern template int ConfigTable::get<int>(std::string_view, const int&) const;
extern template std::int64_t ConfigTable::get<std::int64_t>(std::string_view,
                                                            const std::int64_t&) const;
extern template double ConfigTable::get<double>(std::string_view, const double&) const;
extern template std::string ConfigTable::get<std::string>(std::string_view,
                                                          const std::string&) const;
extern template std::vector<double> ConfigTable::get<std::vector<double>>(
    std::string_view, const std::vector<double>&) const;
extern template std::vector<std::string> ConfigTable::get<std::vector<std::string>>(
    std::string_view, const std::vector<std::string>&) const;

// Edit distance, for "did you mean". Exposed for tests.
std::size_t editDistance(std::string_view a, std::string_view b);

}  // namespace nvs
