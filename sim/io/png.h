#pragma once
// Greyscale PNG through libpng (docs/contracts.md): camera counts, 8 bit or 16 bit.

#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "sim/core/image.h"
#include "sim/io/image_file.h"

namespace nvs::io {

// The colour chunks a PNG carries. None: IHDR, IDAT and IEND only (`nvstim sensor`).
// Srgb: what libpng's simplified API writes for PNG_FORMAT_GRAY and PNG_FORMAT_LINEAR_Y (the
// png:DIR sink): an sRGB chunk on an 8-bit file, gAMA 1.0 and cHRM of the sRGB primaries on a
// 16-bit (linear) one.
enum class PngColour { None, Srgb };

// Writes `img` to `fd` (not closed) as an 8-bit (the low byte of each sample) or 16-bit
// greyscale PNG. 0 or -errno (-EIO when libpng fails). Allocates (libpng, zlib, one row).
int writePng(int fd, ImageView<const std::uint16_t> img, int bitDepth, PngColour colour) noexcept;
// Writes `path` in place, 8 bit when maxValue < 256, else 16 bit, no colour chunks; SetupError
// naming it on failure.
void writePng(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue);

// An 8- or 16-bit greyscale PNG from bytes in memory (16-bit files are read raw, without
// libpng's gamma conversion, every Adam7 pass into the whole image); `maxValue` receives 255
// or 65535. Other PNGs are converted to 8-bit grey by libpng's simplified API.
ImageU16 parsePng(std::string_view bytes, const std::string& name, const ImageLimits& limits,
                  int* maxValue = nullptr);

}  // namespace nvs::io
