#pragma once
// Where nvstim finds its shipped data and keeps its caches, as a plain value passed to every
// object that reads them when it is created. sim/ reads no environment variable and keeps no
// global path: the runtime decides (rt/cli/data_dirs.h), tests give their own.

#include <filesystem>

namespace nvs {

struct DataDirs {
    // config/: camera presets, spectra, the atmosphere's SPECTRL2 table, the star catalogue,
    // FFTW wisdom, DBC files.
    std::filesystem::path config;
    // Disk caches (the atmosphere tables); empty: no disk cache (tables are built each time).
    std::filesystem::path cache;
};

}  // namespace nvs
