#include "rt/sweep/json.h"

#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstdlib>

#include "sim/core/error.h"

namespace nvs::rt::sweep {

Json Json::boolean(bool v) {
    Json j;
    j.kind_ = Kind::Bool;
    j.bool_ = v;
    return j;
}
Json Json::number(double v) {
    Json j;
    j.kind_ = Kind::Number;
    j.number_ = v;
    return j;
}
Json Json::string(std::string v) {
    Json j;
    j.kind_ = Kind::String;
    j.text_ = std::move(v);
    return j;
}
Json Json::array() {
    Json j;
    j.kind_ = Kind::Array;
    return j;
}
Json Json::object() {
    Json j;
    j.kind_ = Kind::Object;
    return j;
}

const Json* Json::find(std::string_view key) const {
    for (const auto& [k, v] : members_)
        if (k == key) return &v;
    return nullptr;
}

double Json::numberOr(std::string_view key, double fallback) const {
    const Json* v = find(key);
    return v != nullptr && v->isNumber() ? v->number_ : fallback;
}

std::string Json::stringOr(std::string_view key, const std::string& fallback) const {
    const Json* v = find(key);
    return v != nullptr && v->isString() ? v->text_ : fallback;
}

Json& Json::set(const std::string& key, Json value) {
    kind_ = Kind::Object;
    for (auto& [k, v] : members_) {
        if (k == key) {
            v = std::move(value);
            return v;
        }
    }
    members_.emplace_back(key, std::move(value));
    return members_.back().second;
}

Json& Json::push(Json value) {
    kind_ = Kind::Array;
    items_.push_back(std::move(value));
    return items_.back();
}

std::string jsonQuote(std::string_view text) {
    std::string out = "\"";
    for (const char c : text) {
        switch (c) {
            case '"':
                out += "\\\"";
                break;
            case '\\':
                out += "\\\\";
                break;
            case '\n':
                out += "\\n";
                break;
            case '\r':
                out += "\\r";
                break;
            case '\t':
                out += "\\t";
                break;
            default:
                if (static_cast<unsigned char>(c) < 0x20) {
                    char buf[8];
                    std::snprintf(buf, sizeof buf, "\\u%04x", static_cast<unsigned>(c));
                    out += buf;
                } else {
                    out += c;
                }
        }
    }
    return out + "\"";
}

std::string jsonNumber(double v) {
    if (!std::isfinite(v)) return "null";
    char buf[40];
    if (v == std::floor(v) && std::fabs(v) <= 9007199254740992.0) {
        std::snprintf(buf, sizeof buf, "%.0f", v);
    } else {
        std::snprintf(buf, sizeof buf, "%.17g", v);
        // The shortest text that reads back as the same double, where one is shorter.
        for (int digits = 6; digits < 17; ++digits) {
            char shorter[40];
            std::snprintf(shorter, sizeof shorter, "%.*g", digits, v);
            if (std::strtod(shorter, nullptr) == v) {
                std::snprintf(buf, sizeof buf, "%s", shorter);
                break;
            }
        }
    }
    return buf;
}

std::string Json::dump() const {
    switch (kind_) {
        case Kind::Null:
            return "null";
        case Kind::Bool:
            return bool_ ? "true" : "false";
        case Kind::Number:
            return jsonNumber(number_);
        case Kind::String:
            return jsonQuote(text_);
        case Kind::Array: {
            std::string out = "[";
            for (std::size_t i = 0; i < items_.size(); ++i)
                out += (i == 0 ? "" : ",") + items_[i].dump();
            return out + "]";
        }
        case Kind::Object: {
            std::string out = "{";
            for (std::size_t i = 0; i < members_.size(); ++i) {
                out += (i == 0 ? "" : ",") + jsonQuote(members_[i].first) + ":" +
                       members_[i].second.dump();
            }
            return out + "}";
        }
    }
    return "null";
}

// Recursive descent over RFC 8259's grammar; depth limited so that a hostile file cannot
// overflow the stack.
class JsonReader {
  public:
    JsonReader(std::string_view text, const std::string& name) : s_(text), name_(name) {}

    Json document() {
        Json v = value(0);
        space();
        if (i_ != s_.size()) fail("text after the value");
        return v;
    }

  private:
    [[noreturn]] void fail(const std::string& what) const {
        throw SetupError(name_ + ": offset " + std::to_string(i_) + ": " + what);
    }
    void space() {
        while (i_ < s_.size() &&
               (s_[i_] == ' ' || s_[i_] == '\t' || s_[i_] == '\n' || s_[i_] == '\r'))
            ++i_;
    }
    bool literal(std::string_view word) {
        if (s_.substr(i_, word.size()) != word) return false;
        i_ += word.size();
        return true;
    }
    Json value(int depth) {
        if (depth > 64) fail("nested too deeply");
        space();
        if (i_ >= s_.size()) fail("a value expected");
        const char c = s_[i_];
        if (c == '{') return object(depth);
        if (c == '[') return array(depth);
        if (c == '"') return Json::string(string());
        if (literal("true")) return Json::boolean(true);
        if (literal("false")) return Json::boolean(false);
        if (literal("null")) return Json();
        return number();
    }
    Json object(int depth) {
        Json o = Json::object();
        ++i_;
        space();
        if (i_ < s_.size() && s_[i_] == '}') {
            ++i_;
            return o;
        }
        for (;;) {
            space();
            if (i_ >= s_.size() || s_[i_] != '"') fail("a member name expected");
            std::string key = string();
            space();
            if (i_ >= s_.size() || s_[i_] != ':') fail("':' expected");
            ++i_;
            o.members_.emplace_back(std::move(key), value(depth + 1));
            space();
            if (i_ < s_.size() && s_[i_] == ',') {
                ++i_;
                continue;
            }
            if (i_ < s_.size() && s_[i_] == '}') {
                ++i_;
                return o;
            }
            fail("',' or '}' expected");
        }
    }
    Json array(int depth) {
        Json a = Json::array();
        ++i_;
        space();
        if (i_ < s_.size() && s_[i_] == ']') {
            ++i_;
            return a;
        }
        for (;;) {
            a.items_.push_back(value(depth + 1));
            space();
            if (i_ < s_.size() && s_[i_] == ',') {
                ++i_;
                continue;
            }
            if (i_ < s_.size() && s_[i_] == ']') {
                ++i_;
                return a;
            }
            fail("',' or ']' expected");
        }
    }
    unsigned hex4() {
        if (i_ + 4 > s_.size()) fail("short \\u escape");
        unsigned v = 0;
        const auto [p, ec] = std::from_chars(s_.data() + i_, s_.data() + i_ + 4, v, 16);
        if (ec != std::errc() || p != s_.data() + i_ + 4) fail("bad \\u escape");
        i_ += 4;
        return v;
    }
    static void utf8(std::string& out, unsigned cp) {
        if (cp < 0x80) {
            out += static_cast<char>(cp);
        } else if (cp < 0x800) {
            out += static_cast<char>(0xc0 | (cp >> 6));
            out += static_cast<char>(0x80 | (cp & 0x3f));
        } else if (cp < 0x10000) {
            out += static_cast<char>(0xe0 | (cp >> 12));
            out += static_cast<char>(0x80 | ((cp >> 6) & 0x3f));
            out += static_cast<char>(0x80 | (cp & 0x3f));
        } else {
            out += static_cast<char>(0xf0 | (cp >> 18));
            out += static_cast<char>(0x80 | ((cp >> 12) & 0x3f));
            out += static_cast<char>(0x80 | ((cp >> 6) & 0x3f));
            out += static_cast<char>(0x80 | (cp & 0x3f));
        }
    }
    std::string string() {
        ++i_;  // the opening quote
        std::string out;
        while (i_ < s_.size() && s_[i_] != '"') {
            const char c = s_[i_++];
            if (static_cast<unsigned char>(c) < 0x20) fail("control character in a string");
            if (c != '\\') {
                out += c;
                continue;
            }
            if (i_ >= s_.size()) break;
            const char e = s_[i_++];
            switch (e) {
                case '"':
                    out += '"';
                    break;
                case '\\':
                    out += '\\';
                    break;
                case '/':
                    out += '/';
                    break;
                case 'b':
                    out += '\b';
                    break;
                case 'f':
                    out += '\f';
                    break;
                case 'n':
                    out += '\n';
                    break;
                case 'r':
                    out += '\r';
                    break;
                case 't':
                    out += '\t';
                    break;
                case 'u': {
                    unsigned cp = hex4();
                    if (cp >= 0xd800 && cp < 0xdc00 && literal("\\u")) {
                        const unsigned lo = hex4();
                        cp = 0x10000 + ((cp - 0xd800) << 10) + (lo - 0xdc00);
                    }
                    utf8(out, cp);
                    break;
                }
                default:
                    fail("bad escape");
            }
        }
        if (i_ >= s_.size()) fail("unterminated string");
        ++i_;
        return out;
    }
    Json number() {
        const std::size_t start = i_;
        while (i_ < s_.size() &&
               (std::isdigit(static_cast<unsigned char>(s_[i_])) != 0 || s_[i_] == '-' ||
                s_[i_] == '+' || s_[i_] == '.' || s_[i_] == 'e' || s_[i_] == 'E'))
            ++i_;
        double v = 0.0;
        const auto [p, ec] = std::from_chars(s_.data() + start, s_.data() + i_, v);
        if (start == i_ || ec != std::errc() || p != s_.data() + i_) {
            i_ = start;
            fail("a value expected");
        }
        return Json::number(v);
    }

    std::string_view s_;
    const std::string& name_;
    std::size_t i_ = 0;
};

Json parseJson(std::string_view text, const std::string& name) {
    return JsonReader(text, name).document();
}

}  // namespace nvs::rt::sweep
