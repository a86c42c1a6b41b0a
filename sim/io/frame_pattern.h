#pragma once
// Numbered image sequences named by a pattern (`nvstim sensor --in/--out`, dataset folders):
// "{frame:06d}" (or "{frame}"; widths up to 20) stands for the frame number.

#include <string>

namespace nvs::io {

// Expands the first well-formed "{frame...}" field; a name without one is returned as is.
std::string expandFramePattern(const std::string& pattern, long long frame);
bool hasFramePattern(const std::string& pattern);

}  // namespace nvs::io
