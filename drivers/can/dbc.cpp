#include <algorithm>
#include <cctype>
#include <charconv>
#include <climits>
#include <cmath>
#include <cstdint>

#include "drivers/can/can.h"
#include "sim/core/error.h"
#include "sim/core/input_file.h"

namespace nvs::drivers {

namespace {

// Bit position p (DBC numbering: byte p/8, bit p%8 counted from the LSB) → the next bit
// toward the LSB of a Motorola signal: down within a byte, then bit 7 of the next byte.
inline int motorolaNext(int pos) {
    return (pos % 8 == 0) ? pos + 15 : pos - 1;
}

}  // namespace

bool extractRaw(const DbcSignal& sig, const std::uint8_t* data, int len,
                std::uint64_t* raw) noexcept {
    std::uint64_t v = 0;
    if (sig.intel) {
        // Intel: bit i of the value is at DBC position start + i.
        for (int i = 0; i < sig.length; ++i) {
            const int pos = sig.startBit + i;
            if (pos / 8 >= len) return false;
            v |= static_cast<std::uint64_t>((data[pos / 8] >> (pos % 8)) & 1u) << i;
        }
    } else {
        // Motorola: the start bit is the MSB; walk toward the LSB.
        int pos = sig.startBit;
        for (int i = 0; i < sig.length; ++i) {
            if (pos / 8 >= len || pos < 0) return false;
            v = (v << 1) | ((data[pos / 8] >> (pos % 8)) & 1u);
            pos = motorolaNext(pos);
        }
    }
    *raw = v;
    return true;
}

bool decodeSignal(const DbcSignal& sig, const std::uint8_t* data, int len, double* value) noexcept {
    std::uint64_t raw = 0;
    if (!extractRaw(sig, data, len, &raw)) return false;
    double r = 0.0;
    if (sig.isSigned) {
        // Two's complement of `length` bits: the sign bit set, every higher bit set too. In
        // unsigned arithmetic, then converted (modular since C++20): 2^63 and the subtraction
        // raw − 2^length overflowed int64 for lengths of 63 and 64.
        if (sig.length < 64 && ((raw >> (sig.length - 1)) & 1u))
            raw |= ~std::uint64_t{0} << sig.length;
        r = static_cast<double>(static_cast<std::int64_t>(raw));
    } else {
        r = static_cast<double>(raw);
    }
    *value = r * sig.factor + sig.offset;
    return true;
}

void encodeSignal(const DbcSignal& sig, double value, std::uint8_t* data, int len) noexcept {
    double r = std::round((value - sig.offset) / sig.factor);
    if (std::isnan(r)) r = 0.0;
    // Clamped to the raw range in integer arithmetic: 2^63 and 2^64 are not representable in
    // the integer types, so a double at the limit must not be converted.
    const int n = sig.length;
    std::uint64_t raw = 0;
    if (sig.isSigned) {
        const double lim = std::ldexp(1.0, n - 1);
        const std::int64_t hi = n == 64 ? INT64_MAX : (std::int64_t{1} << (n - 1)) - 1;
        const std::int64_t lo = n == 64 ? INT64_MIN : -(std::int64_t{1} << (n - 1));
        const std::int64_t v = r >= lim ? hi : (r < -lim ? lo : static_cast<std::int64_t>(r));
        raw = static_cast<std::uint64_t>(v);
    } else {
        const double lim = std::ldexp(1.0, n);
        const std::uint64_t hi = n == 64 ? UINT64_MAX : (std::uint64_t{1} << n) - 1;
        raw = r <= 0.0 ? 0 : (r >= lim ? hi : static_cast<std::uint64_t>(r));
    }
    if (n < 64) raw &= (static_cast<std::uint64_t>(1) << n) - 1;
    if (sig.intel) {
        for (int i = 0; i < sig.length; ++i) {
            const int pos = sig.startBit + i;
            if (pos / 8 >= len) return;
            const auto mask = static_cast<std::uint8_t>(1u << (pos % 8));
            data[pos / 8] = static_cast<std::uint8_t>(((raw >> i) & 1u) ? data[pos / 8] | mask
                                                                        : data[pos / 8] & ~mask);
        }
    } else {
        int pos = sig.startBit;
        for (int i = sig.length - 1; i >= 0; --i) {
            if (pos / 8 >= len || pos < 0) return;
            const auto mask = static_cast<std::uint8_t>(1u << (pos % 8));
            data[pos / 8] = static_cast<std::uint8_t>(((raw >> i) & 1u) ? data[pos / 8] | mask
                                                                        : data[pos / 8] & ~mask);
            pos = motorolaNext(pos);
        }
    }
}

bool inDeclaredRange(const DbcSignal& sig, double value) noexcept {
    if (!std::isfinite(value)) return false;
    if (sig.min == 0.0 && sig.max == 0.0) return true;  // [0|0]: no range declared
    // Half a raw step of slack: raw·factor + offset is rounded, the DBC's limits are not.
    const double slack = 0.5 * std::fabs(sig.factor);
    return value >= sig.min - slack && value <= sig.max + slack;
}

// ---- DBC text ------------------------------------------------------------------------------
// Hand-written and bounded: one pass over each line, no recursion, no backtracking (a
// std::regex over a whole line recursed once per character and overflowed the stack on a
// 40 KB line). Lines are at most kDbcMaxLineBytes; numbers at most 64 characters.

namespace {

constexpr std::size_t kMaxNumberChars = 64;

// A cursor over one line; every method skips leading blanks and consumes only on success.
class Cursor {
  public:
    explicit Cursor(std::string_view s) : s_(s) {}
    void blanks() {
        while (i_ < s_.size() && (s_[i_] == ' ' || s_[i_] == '\t'))
            ++i_;
    }
    bool atEnd() {
        blanks();
        return i_ == s_.size();
    }
    bool lit(char c) {
        blanks();
        if (i_ < s_.size() && s_[i_] == c) {
            ++i_;
            return true;
        }
        return false;
    }
    // A name: letters, digits and '_' (the \w+ of the DBC grammar).
    bool ident(std::string_view* out) {
        blanks();
        const std::size_t b = i_;
        while (i_ < s_.size() &&
               (std::isalnum(static_cast<unsigned char>(s_[i_])) != 0 || s_[i_] == '_'))
            ++i_;
        if (i_ == b) return false;
        *out = s_.substr(b, i_ - b);
        return true;
    }
    // Decimal digits only, at most `maxDigits`, value at most `max`.
    bool unsignedInt(std::uint64_t max, std::uint64_t* out) {
        blanks();
        const std::size_t b = i_;
        while (i_ < s_.size() && s_[i_] >= '0' && s_[i_] <= '9')
            ++i_;
        const auto r = std::from_chars(s_.data() + b, s_.data() + i_, *out);
        if (i_ == b || r.ec != std::errc() || *out > max) {
            i_ = b;
            return false;
        }
        return true;
    }
    // A finite decimal floating-point number ("1E-07", "-90", "+0.5").
    bool number(double* out) {
        blanks();
        const std::size_t b = i_;
        while (i_ < s_.size() &&
               (std::isdigit(static_cast<unsigned char>(s_[i_])) != 0 || s_[i_] == '.' ||
                s_[i_] == 'e' || s_[i_] == 'E' || s_[i_] == '+' || s_[i_] == '-'))
            ++i_;
        std::size_t from = b;
        if (from < i_ && s_[from] == '+') ++from;  // from_chars takes no '+'
        const auto r = std::from_chars(s_.data() + from, s_.data() + i_, *out);
        if (i_ - b > kMaxNumberChars || from == i_ || r.ec != std::errc() ||
            r.ptr != s_.data() + i_ || !std::isfinite(*out)) {
            i_ = b;
            return false;
        }
        return true;
    }
    // "text" (no escapes in DBC unit strings).
    bool quoted(std::string_view* out) {
        if (!lit('"')) return false;
        const std::size_t close = s_.find('"', i_);
        if (close == std::string_view::npos) return false;
        *out = s_.substr(i_, close - i_);
        i_ = close + 1;
        return true;
    }

  private:
    std::string_view s_;
    std::size_t i_ = 0;
};

// BO_ <id> <name> : <size> <transmitter>
bool parseBo(std::string_view line, DbcMessage* msg) {
    Cursor c(line.substr(3));
    std::uint64_t rawId = 0, size = 0;
    std::string_view name, tx;
    if (!c.unsignedInt(0xFFFFFFFFu, &rawId) || !c.ident(&name) || !c.lit(':') ||
        !c.unsignedInt(1000, &size) || !c.ident(&tx) || !c.atEnd()) {
        return false;
    }
    msg->extended = (rawId & 0x80000000u) != 0;
    msg->id = static_cast<std::uint32_t>(rawId & 0x1FFFFFFFu);
    msg->name = std::string(name);
    msg->size = static_cast<int>(size);
    return true;
}

// SG_ <name> [M|mN[M]] : <start>|<length>@<order><sign> (<factor>,<offset>) [<min>|<max>]
//     "<unit>" <receivers>
bool parseSg(std::string_view line, DbcSignal* s) {
    Cursor c(line.substr(3));  // after "SG_"
    std::string_view name, mux, unit;
    std::uint64_t start = 0, length = 0, order = 0;
    if (!c.ident(&name)) return false;
    if (c.ident(&mux)) {
        // Multiplexor "M" or multiplexed "m<digits>" (optionally "M" after): accepted, unused.
        const bool ok = mux == "M" || (mux.size() > 1 && mux[0] == 'm' &&
                                       std::isdigit(static_cast<unsigned char>(mux[1])) != 0);
        if (!ok) return false;
    }
    if (!c.lit(':') || !c.unsignedInt(511, &start) || !c.lit('|') || !c.unsignedInt(64, &length) ||
        !c.lit('@') || !c.unsignedInt(1, &order)) {
        return false;
    }
    const bool minus = c.lit('-');
    if (!minus && !c.lit('+')) return false;
    if (!c.lit('(') || !c.number(&s->factor) || !c.lit(',') || !c.number(&s->offset) ||
        !c.lit(')') || !c.lit('[') || !c.number(&s->min) || !c.lit('|') || !c.number(&s->max) ||
        !c.lit(']') || !c.quoted(&unit)) {
        return false;
    }
    s->name = std::string(name);
    s->startBit = static_cast<int>(start);
    s->length = static_cast<int>(length);
    s->intel = order == 1;
    s->isSigned = minus;
    s->unit = std::string(unit);
    return true;  // the receivers that follow are not used
}

void checkSignal(const DbcSignal& s, const DbcMessage& msg, const FileLoc& loc) {
    if (s.length < 1 || s.length > 64) throw SetupError(loc, "signal length must be 1..64");
    if (s.factor == 0.0) throw SetupError(loc, "signal factor must not be 0");
    if (s.min > s.max) throw SetupError(loc, "signal '" + s.name + "': [min|max] with min > max");
    std::uint8_t probe[64] = {};
    std::uint64_t raw = 0;
    if (!extractRaw(s, probe, msg.size, &raw)) {
        throw SetupError(loc, "signal '" + s.name + "' does not fit message '" + msg.name +
                                  "' of " + std::to_string(msg.size) + " bytes");
    }
}

}  // namespace

DbcDatabase DbcDatabase::parse(std::string_view text, const std::string& fileName) {
    DbcDatabase db;
    int lineNo = 0;
    bool inMessage = false;  // the last BO_ still collects SG_ lines
    std::size_t pos = 0;
    while (pos < text.size()) {
        const std::size_t eol = std::min(text.find('\n', pos), text.size());
        std::string_view line = text.substr(pos, eol - pos);
        pos = eol + 1;
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        const FileLoc loc{fileName, lineNo, 1};
        if (line.size() > kDbcMaxLineBytes) {
            throw SetupError(loc, "line of " + std::to_string(line.size()) +
                                      " bytes, longer than the limit of " +
                                      std::to_string(kDbcMaxLineBytes));
        }
        const std::size_t first = line.find_first_not_of(" \t");
        if (line.substr(0, 4) == "BO_ ") {
            DbcMessage msg;
            if (!parseBo(line, &msg)) throw SetupError(loc, "malformed BO_ line");
            if (msg.size > 64) throw SetupError(loc, "message size must be 0..64");
            db.messages_.push_back(std::move(msg));
            inMessage = true;
        } else if (first != std::string_view::npos && line.substr(first, 4) == "SG_ ") {
            if (!inMessage) throw SetupError(loc, "SG_ outside a BO_ message");
            DbcSignal s;
            if (!parseSg(line.substr(first), &s)) throw SetupError(loc, "malformed SG_ line");
            checkSignal(s, db.messages_.back(), loc);
            db.messages_.back().signals.push_back(std::move(s));
        } else if (!line.empty() && line[0] != ' ' && line[0] != '\t') {
            inMessage = false;  // another section
        }
    }
    std::sort(db.messages_.begin(), db.messages_.end(), [](const auto& a, const auto& b) {
        return a.extended != b.extended ? !a.extended : a.id < b.id;
    });
    for (std::size_t i = 1; i < db.messages_.size(); ++i) {
        if (db.messages_[i].id == db.messages_[i - 1].id &&
            db.messages_[i].extended == db.messages_[i - 1].extended) {
            throw SetupError(FileLoc{fileName, 0, 0},
                             "duplicate message id " + std::to_string(db.messages_[i].id));
        }
    }
    return db;
}

DbcDatabase DbcDatabase::load(const std::string& path) {
    return parse(readInputFile(path, kMaxConfigFileBytes, "DBC file"), path);
}

const DbcMessage* DbcDatabase::find(std::uint32_t id, bool extended) const noexcept {
    auto it = std::lower_bound(messages_.begin(), messages_.end(), std::make_pair(extended, id),
                               [](const DbcMessage& m, const std::pair<bool, std::uint32_t>& k) {
                                   return m.extended != k.first ? !m.extended : m.id < k.second;
                               });
    if (it == messages_.end() || it->id != id || it->extended != extended) return nullptr;
    return &*it;
}

const DbcMessage* DbcDatabase::findByName(std::string_view name) const noexcept {
    for (const auto& m : messages_) {
        if (m.name == name) return &m;
    }
    return nullptr;
}

}  // namespace nvs::drivers
