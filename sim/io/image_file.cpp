#include "sim/io/image_file.h"

#include <fcntl.h>
#include <unistd.h>

#include <cctype>
#include <cerrno>
#include <cstring>
#include <string>

#include "sim/core/error.h"
#include "sim/core/input_file.h"
#include "sim/io/exr.h"
#include "sim/io/png.h"
#include "sim/io/pnm.h"

namespace nvs::io {

namespace {

[[noreturn]] void fail(const std::filesystem::path& p, const std::string& msg) {
    throw SetupError(FileLoc{p.string(), 0, 0}, msg);
}

std::string lowerExtension(const std::filesystem::path& p) {
    std::string s = p.extension().string();
    for (char& ch : s)
        ch = static_cast<char>(std::tolower(static_cast<unsigned char>(ch)));
    return s;
}

}  // namespace

void checkImageSize(std::int64_t w, std::int64_t h, const ImageLimits& lim,
                    const std::string& name) {
    if (w <= 0 || h <= 0) throw SetupError(FileLoc{name}, "bad image size");
    if (lim.width > 0 && (w != lim.width || h != lim.height)) {
        throw SetupError(FileLoc{name}, "image is " + std::to_string(w) + "x" + std::to_string(h) +
                                            ", expected " + std::to_string(lim.width) + "x" +
                                            std::to_string(lim.height));
    }
    if (w > lim.maxWidth || h > lim.maxHeight) {
        throw SetupError(FileLoc{name}, "image is " + std::to_string(w) + "x" + std::to_string(h) +
                                            ", larger than the limit of " +
                                            std::to_string(lim.maxWidth) + "x" +
                                            std::to_string(lim.maxHeight));
    }
}

RadianceFile readRadiance(const std::filesystem::path& path, const ImageLimits& limits) {
    const std::string ext = lowerExtension(path);
    if (ext != ".exr" && ext != ".pfm") fail(path, "input must be .exr or .pfm");
    const std::string bytes = readInputFile(path, kMaxImageFileBytes, "image file");
    RadianceFile r;
    if (ext == ".pfm") {
        r.image = parsePfm(bytes, path.string(), limits);
        return r;
    }
    ExrImage exr = parseExr(bytes, path.string(), limits);
    r.image = std::move(exr.image);
    r.unit = exr.attribute(kExrUnit);
    r.spectrum = exr.attribute(kExrSpectrum);
    return r;
}

CountsFile readCounts(const std::filesystem::path& path, const ImageLimits& limits) {
    const std::string ext = lowerExtension(path);
    if (ext != ".pgm" && ext != ".png") fail(path, "frames must be .pgm or .png");
    // A regular file only (a FIFO or /dev/zero is refused before it is read), bounded.
    const std::string bytes = readInputFile(path, kMaxImageFileBytes, "frame");
    CountsFile c;
    c.image = ext == ".pgm" ? parsePgm(bytes, path.string(), limits, &c.maxValue)
                            : parsePng(bytes, path.string(), limits, &c.maxValue);
    return c;
}

int writeAll(int fd, const void* data, std::size_t size) noexcept {
    const auto* p = static_cast<const unsigned char*>(data);
    while (size > 0) {
        const ssize_t n = ::write(fd, p, size);
        if (n < 0) {
            if (errno == EINTR) continue;
            return -errno;
        }
        if (n == 0) return -EIO;
        p += n;
        size -= static_cast<std::size_t>(n);
    }
    return 0;
}

FileOut::FileOut(const std::filesystem::path& path) : path_(path) {
    fd_ = ::open(path.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd_ < 0) fail(path, std::string("cannot create: ") + std::strerror(errno));
}

FileOut::~FileOut() {
    if (fd_ >= 0) ::close(fd_);
}

void FileOut::write(const void* data, std::size_t size) {
    const int rc = writeAll(fd_, data, size);
    if (rc != 0) close(rc);
}

void FileOut::close(int rc, const char* what) {
    if (fd_ < 0) return;
    const int fd = fd_;
    fd_ = -1;
    if (::close(fd) != 0 && rc == 0) rc = -errno;
    if (rc != 0) fail(path_, std::string(what) + ": " + std::strerror(-rc));
}

}  // namespace nvs::io
