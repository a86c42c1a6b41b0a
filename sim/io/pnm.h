#pragma once
// Netpbm-style files (docs/contracts.md): PGM (P5, netpbm pgm(5)) for camera counts and PFM
// (the portable float map) for radiance. Both are a text header of whitespace-separated
// fields ('#' comments allowed, exactly one whitespace byte before the samples) and raw
// samples:
//   PGM  "P5" width height maxval; samples 8 bit when maxval < 256, else 16 bit big-endian;
//        rows top to bottom.
//   PFM  "Pf" (grey) or "PF" (colour, 3 samples a pixel) width height scale; 32-bit floats,
//        little-endian when scale < 0, big-endian when > 0; rows bottom to top.
// nvstim writes "P5\nW H\nMAXVAL\n" and "Pf\nW H\n-1.0\n" (little-endian grey).

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>
#include <string_view>

#include "sim/core/image.h"
#include "sim/io/image_file.h"

namespace nvs::io {

// From bytes in memory; `name` names the input in errors. A PF file gives its first channel.
ImageF parsePfm(std::string_view bytes, const std::string& name, const ImageLimits& limits);
// 8- or 16-bit P5 into uint16; `maxValue`, when given, receives the header's maximum value.
ImageU16 parsePgm(std::string_view bytes, const std::string& name, const ImageLimits& limits,
                  int* maxValue = nullptr);
// Reads a P5 PGM from a regular file (at most 1 GiB).
ImageU16 readPgm(const std::filesystem::path& path, const ImageLimits& limits = {});

// The size of a PGM file of `width`×`height` samples with `maxValue` (header included).
std::size_t pgmFileBytes(int width, int height, int maxValue) noexcept;
// Writes the whole PGM file (header, then the samples; a sample's bits above maxValue's byte
// width are dropped) into `out`, which holds pgmFileBytes(); returns the bytes written.
std::size_t encodePgm(ImageView<const std::uint16_t> img, int maxValue,
                      unsigned char* out) noexcept;
// Writes `path` in place (sim/io/image_file.h, FileOut); SetupError naming it on failure.
void writePgm(const std::filesystem::path& path, ImageView<const std::uint16_t> img, int maxValue);
// A grey PFM, little-endian (scale -1.0).
void writePfm(const std::filesystem::path& path, ImageView<const float> img);

}  // namespace nvs::io
