#pragma once
// Image files for `nvstim sensor`: inputs OpenEXR or PFM (float radiance), outputs PGM/PNG
// (8 or 16 bit) or EXR. PGM and PFM are a few lines of header and raw samples, written here;
// PNG goes through libpng and EXR through OpenEXR. Setup-phase code: errors are SetupError
// naming the file.

#include <filesystem>
#include <string>
#include <string_view>

#include "sim/core/image.h"

namespace nvs::sensor {

struct RadianceFile {
    ImageF image;
    std::string unit;      // from an EXR header written by nvstim ("" if absent)
    std::string spectrum;  // likewise
};

// What an image input may be (docs/reliability-inputs.md): its header's size is checked
// against these before any pixel memory is allocated, and against the bytes the file holds.
struct ImageLimits {
    int maxWidth = 16384;
    int maxHeight = 16384;
    // When > 0: the size the image must have (the camera's), checked from the header.
    int width = 0;
    int height = 0;
};

// Reads .exr (channel Y, else R, else the first) or .pfm (Pf grey, or PF colour → channel 0)
// from a regular file of at most 1 GiB (sim/core/input_file.h).
RadianceFile readRadiance(const std::filesystem::path& path, const ImageLimits& limits = {});
// The same from bytes in memory; `name` names the input in errors (fuzz targets, tests).
ImageF parsePfm(std::string_view bytes, const std::string& name, const ImageLimits& limits);
RadianceFile parseExr(std::string_view bytes, const std::string& name, const ImageLimits& limits);
ImageU16 parsePgm(std::string_view bytes, const std::string& name, const ImageLimits& limits);
// Writes a float image as single-channel EXR (channel Y, float), with nvstim header strings.
void writeExr(const std::filesystem::path& path, ImageView<const float> img,
              const std::string& unit, const std::string& spectrum);
void writePfm(const std::filesystem::path& path, ImageView<const float> img);
// PGM (P5) or PNG, 8 bit when maxValue < 256, else 16 bit.
void writePgm(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue);
void writePng(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue);
// Reads a P5 PGM (8 or 16 bit) into uint16.
ImageU16 readPgm(const std::filesystem::path& path, const ImageLimits& limits = {});

// Expands "{frame:06d}" (or "{frame}"; widths up to 20) in a pattern; a name without a
// well-formed field is returned as is.
std::string expandFramePattern(const std::string& pattern, long long frame);
bool hasFramePattern(const std::string& pattern);

}  // namespace nvs::sensor
