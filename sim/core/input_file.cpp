#include "sim/core/input_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <system_error>

#include "sim/core/error.h"

namespace nvs {

namespace {

// Closes a descriptor on every path out of readInputFile.
struct Fd {
    int fd;
    ~Fd() {
        if (fd >= 0) ::close(fd);
    }
};

[[noreturn]] void fail(const std::filesystem::path& path, const std::string& what,
                       const std::string& why) {
    throw SetupError(FileLoc{path.string()}, what + ": " + why);
}

[[noreturn]] void cannotOpen(const std::filesystem::path& path, const std::string& what) {
    throw SetupError(FileLoc{path.string()}, "cannot open " + what + ": " + std::strerror(errno));
}

std::string limitText(std::uintmax_t bytes) {
    return std::to_string(bytes >> 20) + " MiB";
}

}  // namespace

std::string readInputFile(const std::filesystem::path& path, std::uintmax_t maxBytes,
                          const std::string& what) {
    // O_NONBLOCK: opening a FIFO with no writer must not block; it is refused just below.
    const Fd f{::open(path.c_str(), O_RDONLY | O_CLOEXEC | O_NONBLOCK | O_NOCTTY)};
    if (f.fd < 0) cannotOpen(path, what);
    struct stat st {};
    if (::fstat(f.fd, &st) != 0)
        fail(path, what, std::string("cannot stat: ") + std::strerror(errno));
    if (!S_ISREG(st.st_mode))
        fail(path, what, std::string(kindOf(st.st_mode)) + ", not a regular file");
    if (static_cast<std::uintmax_t>(st.st_size) > maxBytes) {
        fail(path, what,
             std::to_string(st.st_size) + " bytes, more than the limit of " + limitText(maxBytes));
    }
    std::string text(static_cast<std::size_t>(st.st_size), '\0');
    std::size_t have = 0;
    // Read to the end (a file that grew since fstat is read up to the limit, then refused).
    for (;;) {
        if (have == text.size()) {
            if (text.size() >= maxBytes) {
                char probe = 0;
                const ssize_t n = ::read(f.fd, &probe, 1);
                if (n == 0) break;
                fail(path, what, "more than the limit of " + limitText(maxBytes));
            }
            text.resize(std::min<std::uintmax_t>(maxBytes, text.size() + 65536));
        }
        const ssize_t n = ::read(f.fd, text.data() + have, text.size() - have);
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) fail(path, what, std::string("read failed: ") + std::strerror(errno));
        if (n == 0) break;
        have += static_cast<std::size_t>(n);
    }
    text.resize(have);
    return text;
}

const char* kindOf(mode_t mode) noexcept {
    if (S_ISDIR(mode)) return "a directory";
    if (S_ISCHR(mode)) return "a character device";
    if (S_ISBLK(mode)) return "a block device";
    if (S_ISFIFO(mode)) return "a FIFO";
    if (S_ISSOCK(mode)) return "a socket";
    if (S_ISLNK(mode)) return "a symbolic link";
    return "not a regular file";
}

bool pathExists(const std::filesystem::path& path) noexcept {
    std::error_code ec;
    return std::filesystem::exists(path, ec);
}

bool isDirectory(const std::filesystem::path& path) noexcept {
    std::error_code ec;
    return std::filesystem::is_directory(path, ec);
}

void requireRegularFile(const std::filesystem::path& path, const std::string& what) {
    struct stat st {};
    if (::stat(path.c_str(), &st) != 0) cannotOpen(path, what);
    if (!S_ISREG(st.st_mode))
        fail(path, what, std::string(kindOf(st.st_mode)) + ", not a regular file");
}

}  // namespace nvs
