#include "drivers/sinks/file_io.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <climits>
#include <cstdio>
#include <cstring>

namespace nvs::drivers {

// ---- StreamWriter ------------------------------------------------------------------------------

int StreamWriter::attach(int fd) noexcept {
    struct stat st {};
    if (::fstat(fd, &st) != 0) return -errno;
    fd_ = fd;
    mayBlock_ = !S_ISREG(st.st_mode) && !S_ISBLK(st.st_mode);
    return 0;
}

int StreamWriter::write(const void* data, std::size_t size) noexcept {
    if (fd_ < 0) return -EBADF;
    if (!mayBlock_) return writeAll(fd_, data, size);
    const auto* p = static_cast<const unsigned char*>(data);
    while (size > 0) {
        pollfd pfd{fd_, POLLOUT, 0};
        // Cancelled: no more waiting, but what can be written without waiting still is.
        const int rc = ::poll(&pfd, 1, cancelled() ? 0 : kSlice_ms);
        if (rc < 0) {
            if (errno == EINTR) continue;
            return -errno;
        }
        if (rc == 0) {
            if (cancelled()) return -ECANCELED;
            continue;
        }
        // POLLERR on a pipe: the reader is gone; the write below reports EPIPE.
        if ((pfd.revents & POLLNVAL) != 0) return -EBADF;
        const std::size_t chunk = std::min<std::size_t>(size, PIPE_BUF);
        const ssize_t n = ::write(fd_, p, chunk);
        if (n < 0) {
            if (errno == EINTR || errno == EAGAIN) continue;
            return -errno;
        }
        if (n == 0) return -EIO;
        p += n;
        size -= static_cast<std::size_t>(n);
    }
    return 0;
}

// ---- AtomicFile --------------------------------------------------------------------------------

int AtomicFile::open(const char* finalPath) noexcept {
    abort();
    const std::size_t len = std::strlen(finalPath);
    if (len + 1 > kMaxPath) return -ENAMETOOLONG;
    std::memcpy(final_, finalPath, len + 1);
    // A device or a FIFO (/dev/null, a named pipe to a consumer) is written in place: a
    // temporary renamed onto it would replace the node itself by a regular file (rename(2)
    // replaces any non-directory; for root that turns /dev/null into a file).
    struct stat st {};
    direct_ = ::stat(finalPath, &st) == 0 && !S_ISREG(st.st_mode) && !S_ISDIR(st.st_mode);
    if (direct_) {
        temp_[0] = '\0';
        fd_ = ::open(finalPath, O_WRONLY | O_CLOEXEC);
        return fd_ < 0 ? -errno : 0;
    }
    std::snprintf(temp_, sizeof temp_, "%s.part", finalPath);
    fd_ = ::open(temp_, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    return fd_ < 0 ? -errno : 0;
}

int AtomicFile::write(const void* data, std::size_t size) noexcept {
    if (fd_ < 0) return -EBADF;
    return writeAll(fd_, data, size);
}

int AtomicFile::truncate(off_t size) noexcept {
    if (fd_ < 0) return -EBADF;
    if (direct_) return -ESPIPE;  // what went to a device or a pipe cannot be taken back
    if (::ftruncate(fd_, size) != 0) return -errno;
    if (::lseek(fd_, size, SEEK_SET) < 0) return -errno;
    return 0;
}

int AtomicFile::commit(bool sync, bool keepOnError) noexcept {
    if (fd_ < 0) return -EBADF;
    int rc = 0;
    // A device or a pipe has no file to make durable (fsync(2): EINVAL on most of them).
    if (sync && !direct_ && ::fsync(fd_) != 0) rc = -errno;
    if (::close(fd_) != 0 && rc == 0) rc = -errno;
    fd_ = -1;
    if (direct_) return rc;
    if (rc != 0 && !keepOnError) {
        ::unlink(temp_);
        return rc;
    }
    if (::rename(temp_, final_) != 0) {
        const int e = -errno;
        ::unlink(temp_);
        return rc != 0 ? rc : e;
    }
    return rc;
}

void AtomicFile::abort() noexcept {
    if (fd_ < 0) return;
    ::close(fd_);
    fd_ = -1;
    if (!direct_) ::unlink(temp_);
}

std::int64_t AtomicFile::size() const noexcept {
    struct stat st {};
    if (fd_ < 0 || ::fstat(fd_, &st) != 0 || !S_ISREG(st.st_mode)) return 0;
    return static_cast<std::int64_t>(st.st_size);
}

}  // namespace nvs::drivers
