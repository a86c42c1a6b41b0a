#pragma once
// The image files nvstim reads and writes (docs/contracts.md), one layer for sim/, drivers/ and
// rt/: OpenEXR (sim/io/exr.h), PNG (sim/io/png.h), PGM and PFM (sim/io/pnm.h). This header
// holds what they share: the limits an input's header is checked against before any pixel
// memory is allocated (docs/reliability-inputs.md), the readers that choose a format by the
// file's extension, and a file descriptor written in place. Setup-phase readers and writers
// throw SetupError naming the file; the descriptor-level writers the sinks use in the frame
// loop return 0 or -errno and never throw.

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

#include "sim/core/image.h"

namespace nvs::io {

// What an image input may be: its header's size is checked against these before any pixel
// memory is allocated, and against the bytes the file holds.
struct ImageLimits {
    int maxWidth = 16384;
    int maxHeight = 16384;
    // When > 0: the size the image must have (the camera's), checked from the header.
    int width = 0;
    int height = 0;
};

// Throws SetupError naming `name` when a header's size is not positive or breaks `limits`.
void checkImageSize(std::int64_t width, std::int64_t height, const ImageLimits& limits,
                    const std::string& name);

// A float image and the nvstim header strings an EXR carries ("" when absent or a PFM).
struct RadianceFile {
    ImageF image;
    std::string unit;      // nvstim.unit
    std::string spectrum;  // nvstim.spectrum
};

// Reads .exr (channel Y, else R, else L, else the first) or .pfm (Pf grey, or PF colour →
// channel 0) from a regular file of at most 1 GiB (sim/core/input_file.h).
RadianceFile readRadiance(const std::filesystem::path& path, const ImageLimits& limits = {});

// Camera counts from a .pgm (P5, 8 or 16 bit) or .png (8 or 16 bit greyscale), with the
// file's maximum value (the PGM header's; 255 or 65535 for a PNG).
struct CountsFile {
    ImageU16 image;
    int maxValue = 0;
};
CountsFile readCounts(const std::filesystem::path& path, const ImageLimits& limits = {});

// write(2) until all bytes are out (retries EINTR and short writes). 0 or -errno.
int writeAll(int fd, const void* data, std::size_t size) noexcept;

// A file written in place by name (created, or truncated: a temporary of the output layer,
// sim/core/output_file.h, which makes it durable and renames it at commit). close() reports
// the first error as SetupError naming the file; the destructor closes without checking.
class FileOut {
  public:
    explicit FileOut(const std::filesystem::path& path);
    ~FileOut();
    FileOut(const FileOut&) = delete;
    FileOut& operator=(const FileOut&) = delete;
    int fd() const { return fd_; }
    const std::filesystem::path& path() const { return path_; }
    void write(const void* data, std::size_t size);
    // `rc` (0 or -errno) is an error the caller met while writing: reported first.
    void close(int rc = 0, const char* what = "write failed");

  private:
    std::filesystem::path path_;
    int fd_ = -1;
};

}  // namespace nvs::io
