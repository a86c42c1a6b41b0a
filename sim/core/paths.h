#pragma once
// Where nvstim finds its shipped data (config/: camera presets, spectra, DBC files).

#include <filesystem>

namespace nvs {

// $NVS_CONFIG_DIR if set, else the source tree's config/ this binary was built from.
std::filesystem::path configDir();

}  // namespace nvs
