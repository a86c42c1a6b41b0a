#include "sim/core/csv.h"

#include <cerrno>
#include <cstdlib>
#include <fstream>
#include <sstream>

#include "sim/core/input_file.h"

namespace nvs {
namespace {

std::string trim(std::string_view s) {
    const auto b = s.find_first_not_of(" \t\r");
    if (b == std::string_view::npos) return {};
    const auto e = s.find_last_not_of(" \t\r");
    return std::string(s.substr(b, e - b + 1));
}

// Splits one record. Quoted fields may hold commas and doubled quotes; they may not span lines
// (none of our tables needs that, and refusing it keeps line numbers exact).
std::vector<std::string> splitRecord(std::string_view line, const FileLoc& loc) {
    std::vector<std::string> fields;
    std::string cur;
    bool quoted = false;
    bool wasQuoted = false;
    for (std::size_t i = 0; i < line.size(); ++i) {
        const char ch = line[i];
        if (quoted) {
            if (ch == '"') {
                if (i + 1 < line.size() && line[i + 1] == '"') {
                    cur += '"';
                    ++i;
                } else {
                    quoted = false;
                }
            } else {
                cur += ch;
            }
        } else if (ch == '"') {
            quoted = true;
            wasQuoted = true;
        } else if (ch == ',') {
            fields.push_back(wasQuoted ? cur : trim(cur));
            cur.clear();
            wasQuoted = false;
        } else {
            cur += ch;
        }
    }
    if (quoted) throw SetupError(loc, "unterminated quoted field");
    fields.push_back(wasQuoted ? cur : trim(cur));
    return fields;
}

}  // namespace

CsvTable CsvTable::load(const std::filesystem::path& path) {
    return parse(readInputFile(path, kMaxTableFileBytes, "CSV file"), path.string());
}

CsvTable CsvTable::parse(std::string_view text, const std::string& name) {
    CsvTable t;
    t.file_ = name;
    int lineNo = 0;
    std::size_t pos = 0;
    while (pos <= text.size()) {
        const std::size_t eol = text.find('\n', pos);
        std::string_view line =
            text.substr(pos, eol == std::string_view::npos ? std::string_view::npos : eol - pos);
        pos = (eol == std::string_view::npos) ? text.size() + 1 : eol + 1;
        ++lineNo;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (lineNo == 1 && line.substr(0, 3) == "\xEF\xBB\xBF") line.remove_prefix(3);  // BOM
        const std::string trimmed = trim(line);
        if (trimmed.empty()) continue;
        if (trimmed[0] == '#') {
            if (t.header_.empty()) t.comments_.push_back(trim(std::string_view(trimmed).substr(1)));
            continue;
        }
        const FileLoc loc{name, lineNo, 0};
        auto fields = splitRecord(line, loc);
        if (t.header_.empty()) {
            t.header_ = std::move(fields);
            t.headerLine_ = lineNo;
            continue;
        }
        if (fields.size() != t.header_.size()) {
            throw SetupError(loc, "expected " + std::to_string(t.header_.size()) +
                                      " fields as in the header, found " +
                                      std::to_string(fields.size()));
        }
        t.rows_.push_back(std::move(fields));
        t.rowLines_.push_back(lineNo);
    }
    if (t.header_.empty()) throw SetupError(FileLoc{name}, "CSV file has no header row");
    return t;
}

std::string CsvTable::commentValue(std::string_view key) const {
    for (const auto& c : comments_) {
        const auto colon = c.find(':');
        if (colon != std::string::npos && trim(std::string_view(c).substr(0, colon)) == key) {
            return trim(std::string_view(c).substr(colon + 1));
        }
    }
    return {};
}

std::size_t CsvTable::column(std::string_view name) const {
    for (std::size_t i = 0; i < header_.size(); ++i) {
        if (header_[i] == name) return i;
    }
    throw SetupError(headerLoc(), "no column '" + std::string(name) + "'");
}

double CsvTable::number(std::size_t row, std::size_t col) const {
    const std::string& cell = rows_[row][col];
    const char* begin = cell.c_str();
    char* end = nullptr;
    errno = 0;
    const double v = std::strtod(begin, &end);
    if (cell.empty() || end != begin + cell.size() || errno == ERANGE) {
        throw SetupError(rowLoc(row),
                         "column '" + header_[col] + "': '" + cell + "' is not a number");
    }
    return v;
}

}  // namespace nvs
