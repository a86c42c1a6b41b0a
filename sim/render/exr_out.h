#pragma once
// Radiance images as OpenEXR files: one FLOAT channel "Y" and string attributes in the header
// (nvstim.unit, nvstim.spectrum as `nvstim sensor` reads them, plus the scenario time and
// frame). Written under a temporary name and renamed, so nothing half-written is left.

#include <filesystem>
#include <string>
#include <utility>
#include <vector>

#include "sim/core/image.h"

namespace nvs::render {

// Writes `path` itself, in place: `nvstim render` hands it a temporary of the output layer
// (sim/core/output_file.h), which checks that the temporary it made is the file it commits, so
// this must not put another file there (a write to a side file renamed over it did).
void writeRadianceExr(const std::filesystem::path& path, ImageView<const float> img,
                      const std::vector<std::pair<std::string, std::string>>& attributes);

// Reads channel Y and every string attribute (for tests).
ImageF readRadianceExr(const std::filesystem::path& path,
                       std::vector<std::pair<std::string, std::string>>* attributes);

}  // namespace nvs::render
