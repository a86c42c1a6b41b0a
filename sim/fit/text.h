#pragma once
// printf-style text for diagnose's causes and reasons, and numbers as the generators write them
// into TOML.

#include <string>

namespace nvs::fit {

// The formatted text (at most 511 characters; longer text is cut).
__attribute__((format(printf, 1, 2))) std::string textf(const char* format, ...);

// A JSON string literal: quotes, backslashes and control characters escaped.
std::string jsonString(const std::string& text);

// A number with nine significant digits, as a TOML value.
inline std::string tomlNumber(double v) {
    return textf("%.9g", v);
}

}  // namespace nvs::fit
