#pragma once
// Image files for `nvstim sensor`: inputs OpenEXR or PFM (float radiance), outputs PGM/PNG
// (8 or 16 bit) or EXR. PGM and PFM are a few lines of header and raw samples, written here;
// PNG goes through libpng and EXR through OpenEXR. Setup-phase code: errors are SetupError
// naming the file.

#include <filesystem>
#include <string>

#include "sim/core/image.h"

namespace nvs::sensor {

struct RadianceFile {
    ImageF image;
    std::string unit;      // from an EXR header written by nvstim ("" if absent)
    std::string spectrum;  // likewise
};

// Reads .exr (channel Y, else R, else the first) or .pfm (Pf grey, or PF colour → channel 0).
RadianceFile readRadiance(const std::filesystem::path& path);
// Writes a float image as single-channel EXR (channel Y, float), with nvstim header strings.
void writeExr(const std::filesystem::path& path, ImageView<const float> img,
              const std::string& unit, const std::string& spectrum);
void writePfm(const std::filesystem::path& path, ImageView<const float> img);
// PGM (P5) or PNG, 8 bit when maxValue < 256, else 16 bit.
void writePgm(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue);
void writePng(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue);
// Reads a P5 PGM (8 or 16 bit) into uint16.
ImageU16 readPgm(const std::filesystem::path& path);

// Expands "{frame:06d}" (or "{frame}") in a pattern; a name without a field is returned as is.
std::string expandFramePattern(const std::string& pattern, long long frame);
bool hasFramePattern(const std::string& pattern);

}  // namespace nvs::sensor
