#pragma once
// Reading an input file at setup, bounded (docs/reliability-inputs.md): only a regular file is
// read where a file is expected (a path to /dev/zero, a FIFO, a terminal or a directory is an
// error, never a hang or an endless read), and never more than a stated number of bytes.
// The file is opened first and checked on the open descriptor (fstat), so the check and the
// read see the same file.
//
//   kMaxConfigFileBytes   TOML (scenario, camera preset, scene), DBC          16 MiB
//   kMaxTableFileBytes    CSV tables (spectra, reflectances, star catalogue)  64 MiB
//   kMaxLogFileBytes      candump telemetry logs                               512 MiB
//   kMaxMeshFileBytes     OBJ meshes                                           512 MiB
//   kMaxImageFileBytes    PFM, PGM, EXR inputs                                 1 GiB

#include <sys/types.h>

#include <cstdint>
#include <filesystem>
#include <string>

namespace nvs {

inline constexpr std::uintmax_t kMaxConfigFileBytes = std::uintmax_t{16} << 20;
inline constexpr std::uintmax_t kMaxTableFileBytes = std::uintmax_t{64} << 20;
inline constexpr std::uintmax_t kMaxLogFileBytes = std::uintmax_t{512} << 20;
inline constexpr std::uintmax_t kMaxMeshFileBytes = std::uintmax_t{512} << 20;
inline constexpr std::uintmax_t kMaxImageFileBytes = std::uintmax_t{1} << 30;

// The whole content of the regular file `path`. Throws SetupError "PATH: <what>: ..." when it
// cannot be opened, is not a regular file, is larger than maxBytes, or a read fails.
std::string readInputFile(const std::filesystem::path& path, std::uintmax_t maxBytes,
                          const std::string& what);

// What a file of mode `mode` (stat's st_mode) is, for messages: "a directory", "a FIFO", ...
const char* kindOf(mode_t mode) noexcept;

// std::filesystem::exists / is_directory without their exception: a name the system refuses
// (a component longer than 255 bytes, ENAMETOOLONG) is simply not there, and the caller's
// "not found" error names it.
bool pathExists(const std::filesystem::path& path) noexcept;
bool isDirectory(const std::filesystem::path& path) noexcept;

// Throws the same SetupError as readInputFile unless `path` names a regular file (after
// following symbolic links); for inputs a library opens by name.
void requireRegularFile(const std::filesystem::path& path, const std::string& what);

}  // namespace nvs
