#pragma once
// Radiance and counts as OpenEXR files (docs/contracts.md): single part, scan lines, one FLOAT
// channel "Y", OpenEXR's default ZIP compression, and nvstim's attributes in the header:
//   nvstim.unit       string  "pe/s/m2/sr", "W/m2/sr" or "DC" (every file nvstim writes but
//                             an EXR without a unit given to writeExr)
//   nvstim.spectrum   string  `nvstim sensor` input spectrum, when given
//   nvstim.scenario, nvstim.frame, nvstim.t_s, ... strings of `nvstim render`
//   nvs_frame int, nvs_t_sample_s double   the exr:DIR sink's frame number and sample time
// Readers walk the header themselves before OpenEXR sees it (sizes against the bytes left and
// the limits), so a hostile file cannot make OpenEXR allocate what its header claims.

#include <filesystem>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

#include "sim/core/image.h"
#include "sim/io/image_file.h"

namespace nvs::io {

inline constexpr const char* kExrUnit = "nvstim.unit";
inline constexpr const char* kExrSpectrum = "nvstim.spectrum";

// The header attributes an EXR is written with (OpenEXR keeps them sorted by name: the order
// here does not change the file).
struct ExrAttributes {
    std::vector<std::pair<std::string, std::string>> strings;
    std::vector<std::pair<std::string, int>> ints;
    std::vector<std::pair<std::string, double>> doubles;
};

struct ExrImage {
    ImageF image;
    std::vector<std::pair<std::string, std::string>> strings;  // every string attribute
    // The string attribute `name`, "" when absent.
    std::string attribute(std::string_view name) const;
};

// From bytes in memory (`name` names the input in errors): channel Y, else R, else L, else the
// first.
ExrImage parseExr(std::string_view bytes, const std::string& name, const ImageLimits& limits);
// The same from a regular file of at most 1 GiB.
ExrImage readExr(const std::filesystem::path& path, const ImageLimits& limits = {});

// Writes `img` to `fd` (not closed) as channel Y. 0 or -errno (-EIO when OpenEXR fails; the
// offset table OpenEXR writes as the file closes is checked too). Allocates (OpenEXR).
int writeExr(int fd, const char* name, ImageView<const float> img,
             const ExrAttributes& attributes) noexcept;
// Writes `path` in place; SetupError naming it on failure.
void writeExr(const std::filesystem::path& path, ImageView<const float> img,
              const ExrAttributes& attributes);

}  // namespace nvs::io
