#pragma once
// One error policy (docs/style.md §8): configuration and setup errors stop with file:line; expected
// runtime failures return values and bump counters; asserts are for bugs only. SetupError is
// the only exception nvstim throws, and never inside the frame loop.

#include <stdexcept>
#include <string>

namespace nvs {

// A place in an input file. line and column are 1-based; 0 means "not known".
struct FileLoc {
    std::string file;
    int line = 0;
    int column = 0;

    // "file:line:column", "file:line" or "file", as much as is known.
    std::string str() const;
};

// A setup error: bad configuration, missing data file, invalid argument. Its message is one
// line that starts with the place ("file:line:col: ") when there is one.
class SetupError : public std::runtime_error {
  public:
    explicit SetupError(const std::string& message) : std::runtime_error(message) {}
    SetupError(const FileLoc& loc, const std::string& message);
};

}  // namespace nvs
