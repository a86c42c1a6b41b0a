#pragma once
// A small CSV reader for tabulated data (spectra, thesis tables). Hand-written because no
// Debian-packaged C++ CSV library is worth a dependency for comma-separated numbers: it reads
// RFC 4180 quoting, '#' comment lines before the header (provenance: "# source: ..."), and keeps
// the line number of every row so errors can name file:line.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "sim/core/error.h"

namespace nvs {

class CsvTable {
  public:
    // Reads the whole file; throws SetupError naming file:line on malformed input.
    static CsvTable load(const std::filesystem::path& path);
    // Parses text as if it were the file `name` (for tests and embedded tables).
    static CsvTable parse(std::string_view text, const std::string& name);

    const std::vector<std::string>& header() const { return header_; }
    // Comment lines before the header, without the leading '#' and surrounding blanks.
    const std::vector<std::string>& comments() const { return comments_; }
    // The value of a "# key: value" comment line, or "" if absent.
    std::string commentValue(std::string_view key) const;

    std::size_t rowCount() const { return rows_.size(); }
    const std::vector<std::string>& row(std::size_t i) const { return rows_[i]; }
    FileLoc rowLoc(std::size_t i) const { return {file_, rowLines_[i], 0}; }
    FileLoc headerLoc() const { return {file_, headerLine_, 0}; }
    const std::string& file() const { return file_; }

    // Index of a column; throws SetupError naming the header line if it is missing.
    std::size_t column(std::string_view name) const;
    // The cell as a number; throws SetupError naming file:line and the column if it is not one.
    double number(std::size_t row, std::size_t col) const;
    bool empty(std::size_t row, std::size_t col) const { return rows_[row][col].empty(); }

  private:
    std::string file_;
    int headerLine_ = 0;
    std::vector<std::string> comments_;
    std::vector<std::string> header_;
    std::vector<std::vector<std::string>> rows_;
    std::vector<int> rowLines_;
};

}  // namespace nvs
