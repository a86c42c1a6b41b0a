#include "drivers/sinks/file_io.h"

#include <fcntl.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

namespace nvs::drivers {

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

int AtomicFile::open(const char* finalPath) noexcept {
    abort();
    const std::size_t len = std::strlen(finalPath);
    if (len + 1 > kMaxPath) return -ENAMETOOLONG;
    std::memcpy(final_, finalPath, len + 1);
    std::snprintf(temp_, sizeof temp_, "%s.part", finalPath);
    fd_ = ::open(temp_, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    return fd_ < 0 ? -errno : 0;
}

int AtomicFile::write(const void* data, std::size_t size) noexcept {
    if (fd_ < 0) return -EBADF;
    return writeAll(fd_, data, size);
}

int AtomicFile::commit(bool sync) noexcept {
    if (fd_ < 0) return -EBADF;
    int rc = 0;
    if (sync && ::fsync(fd_) != 0) rc = -errno;
    if (::close(fd_) != 0 && rc == 0) rc = -errno;
    fd_ = -1;
    if (rc == 0 && ::rename(temp_, final_) != 0) rc = -errno;
    if (rc != 0) ::unlink(temp_);
    return rc;
}

void AtomicFile::abort() noexcept {
    if (fd_ < 0) return;
    ::close(fd_);
    fd_ = -1;
    ::unlink(temp_);
}

}  // namespace nvs::drivers
