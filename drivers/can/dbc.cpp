#include <algorithm>
#include <cmath>
#include <fstream>
#include <regex>
#include <sstream>

#include "drivers/can/can.h"
#include "sim/core/error.h"

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
    if (sig.isSigned && sig.length < 64 && ((raw >> (sig.length - 1)) & 1u)) {
        // Two's complement: subtract 2^length.
        r = static_cast<double>(static_cast<std::int64_t>(raw) -
                                (static_cast<std::int64_t>(1) << sig.length));
    } else if (sig.isSigned && sig.length == 64) {
        r = static_cast<double>(static_cast<std::int64_t>(raw));
    } else {
        r = static_cast<double>(raw);
    }
    *value = r * sig.factor + sig.offset;
    return true;
}

void encodeSignal(const DbcSignal& sig, double value, std::uint8_t* data, int len) noexcept {
    double r = std::round((value - sig.offset) / sig.factor);
    const double span = std::ldexp(1.0, sig.length);
    const double lo = sig.isSigned ? -span / 2 : 0.0;
    const double hi = sig.isSigned ? span / 2 - 1 : span - 1;
    r = std::clamp(r, lo, hi);
    std::uint64_t raw = static_cast<std::uint64_t>(static_cast<std::int64_t>(r));
    if (sig.length < 64) raw &= (static_cast<std::uint64_t>(1) << sig.length) - 1;
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

DbcDatabase DbcDatabase::parse(std::string_view text, const std::string& fileName) {
    static const std::regex kBo(R"(^BO_\s+(\d+)\s+(\w+)\s*:\s*(\d+)\s+(\w+)\s*$)");
    static const std::regex kSg(
        R"(^\s*SG_\s+(\w+)\s*(?:(M|m\d+M?)\s*)?:\s*(\d+)\|(\d+)@([01])([+-])\s*\(\s*([-+0-9.eE]+)\s*,\s*([-+0-9.eE]+)\s*\)\s*\[\s*([-+0-9.eE]+)\s*\|\s*([-+0-9.eE]+)\s*\]\s*"([^"]*)\"\s*(.*)$)");
    DbcDatabase db;
    std::istringstream in{std::string(text)};
    std::string line;
    int lineNo = 0;
    DbcMessage* current = nullptr;
    while (std::getline(in, line)) {
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.pop_back();
        const FileLoc loc{fileName, lineNo, 1};
        std::smatch m;
        if (line.rfind("BO_ ", 0) == 0) {
            if (!std::regex_match(line, m, kBo)) throw SetupError(loc, "malformed BO_ line");
            DbcMessage msg;
            const std::uint64_t rawId = std::stoull(m[1].str());
            msg.extended = (rawId & 0x80000000u) != 0;
            msg.id = static_cast<std::uint32_t>(rawId & 0x1FFFFFFFu);
            msg.name = m[2].str();
            msg.size = std::stoi(m[3].str());
            if (msg.size < 0 || msg.size > 64) throw SetupError(loc, "message size must be 0..64");
            db.messages_.push_back(std::move(msg));
            current = &db.messages_.back();
        } else if (line.find("SG_ ") != std::string::npos &&
                   line.find_first_not_of(" \t") == line.find("SG_ ")) {
            if (current == nullptr) throw SetupError(loc, "SG_ outside a BO_ message");
            if (!std::regex_match(line, m, kSg)) throw SetupError(loc, "malformed SG_ line");
            DbcSignal s;
            s.name = m[1].str();
            s.startBit = std::stoi(m[3].str());
            s.length = std::stoi(m[4].str());
            s.intel = m[5].str() == "1";
            s.isSigned = m[6].str() == "-";
            s.factor = std::stod(m[7].str());
            s.offset = std::stod(m[8].str());
            s.min = std::stod(m[9].str());
            s.max = std::stod(m[10].str());
            s.unit = m[11].str();
            if (s.length < 1 || s.length > 64) throw SetupError(loc, "signal length must be 1..64");
            if (s.factor == 0.0) throw SetupError(loc, "signal factor must not be 0");
            std::uint8_t probe[64] = {};
            std::uint64_t raw = 0;
            if (!extractRaw(s, probe, current->size, &raw)) {
                throw SetupError(loc, "signal '" + s.name + "' does not fit message '" +
                                          current->name + "' of " + std::to_string(current->size) +
                                          " bytes");
            }
            current->signals.push_back(std::move(s));
        } else if (!line.empty() && line[0] != ' ' && line[0] != '\t') {
            current = nullptr;  // another section
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
    std::ifstream f(path);
    if (!f) throw SetupError("DBC file '" + path + "': cannot open");
    std::stringstream ss;
    ss << f.rdbuf();
    return parse(ss.str(), path);
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
