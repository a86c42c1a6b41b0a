#pragma once
// The JSON a sweep reads and writes (docs/contracts.md, "sweep"): its manifest lines, the
// per-job result files and `nvstim run`'s statistics. A small reader of RFC 8259 text (no
// Debian-packaged C++ JSON library is worth a dependency for flat objects) and the writers of
// strings and numbers. Objects keep their keys in file order.

#include <cstdint>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace nvs::rt::sweep {

class Json {
  public:
    enum class Kind { Null, Bool, Number, String, Array, Object };

    Json() = default;
    static Json boolean(bool v);
    static Json number(double v);
    static Json string(std::string v);
    static Json array();
    static Json object();

    Kind kind() const { return kind_; }
    bool isNull() const { return kind_ == Kind::Null; }
    bool isNumber() const { return kind_ == Kind::Number; }
    bool isString() const { return kind_ == Kind::String; }
    bool isObject() const { return kind_ == Kind::Object; }
    bool isArray() const { return kind_ == Kind::Array; }

    bool asBool() const { return bool_; }
    double asNumber() const { return number_; }
    const std::string& asString() const { return text_; }
    const std::vector<Json>& items() const { return items_; }
    const std::vector<std::pair<std::string, Json>>& members() const { return members_; }

    // The member `key` of an object, or nullptr (also for a non-object).
    const Json* find(std::string_view key) const;
    // A member's number or string, or `fallback` where it is absent or of another kind.
    double numberOr(std::string_view key, double fallback) const;
    std::string stringOr(std::string_view key, const std::string& fallback) const;

    // Building: set() replaces a member of the same key (keeps its place) or appends.
    Json& set(const std::string& key, Json value);
    Json& push(Json value);

    // Compact text on one line (numbers with up to 17 significant digits, integers exact).
    std::string dump() const;

  private:
    friend class JsonReader;
    Kind kind_ = Kind::Null;
    bool bool_ = false;
    double number_ = 0.0;
    std::string text_;
    std::vector<Json> items_;
    std::vector<std::pair<std::string, Json>> members_;
};

// Parses one JSON value (surrounding whitespace allowed). Throws SetupError "NAME: offset N:
// what" where the text is not JSON.
Json parseJson(std::string_view text, const std::string& name);

// A JSON string literal, quotes included (control characters and quotes escaped).
std::string jsonQuote(std::string_view text);
// A number as JSON: integers in ±2^53 without a fraction, else 17 significant digits;
// NaN and infinities, which JSON lacks, as null.
std::string jsonNumber(double v);

}  // namespace nvs::rt::sweep
