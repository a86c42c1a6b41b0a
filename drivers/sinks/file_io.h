#pragma once
// File writing that leaves nothing corrupt behind (docs/design.md §7 "nothing half-written"): a
// file is written under a temporary name beside its final path and renamed into place only when
// complete; on any error the temporary is removed. All calls return 0 or -errno.
//
// Streams (y4m, JSON lines) are the exception on purpose: what they already hold stays valid.
// After a failed write a stream is cut back to its last whole record (truncate()) and then
// committed with keepOnError, so a full disk keeps every frame written before it filled.

#include <sys/types.h>

#include <atomic>
#include <cstddef>
#include <cstdint>
#include <string>

#include "sim/io/image_file.h"

namespace nvs::drivers {

// write(2) until all bytes are out (retries EINTR and short writes). 0 or -errno.
using io::writeAll;

// Writes to a descriptor that may block on its reader (pipe, FIFO, socket, terminal) without
// ever blocking for long: it waits for room with poll(2) in slices of kSlice_ms and writes at
// most PIPE_BUF bytes after each wait (a pipe that polls writable has a free page, so such a
// write does not block; pipe(7), "PIPE_BUF" and pipe_write()/pipe_poll() in fs/pipe.c). Once
// cancel() has been called a write that would wait returns -ECANCELED at once. Regular files
// and block devices never wait for a reader and are written plainly.
class StreamWriter {
  public:
    static constexpr int kSlice_ms = 50;
    // fstat()s `fd` (not owned) to choose the plain or the polled path. 0 or -errno.
    int attach(int fd) noexcept;
    int write(const void* data, std::size_t size) noexcept;
    void cancel() noexcept { cancel_.store(true, std::memory_order_release); }
    bool cancelled() const noexcept { return cancel_.load(std::memory_order_acquire); }
    int fd() const noexcept { return fd_; }

  private:
    int fd_ = -1;
    bool mayBlock_ = false;
    std::atomic<bool> cancel_{false};
};

class AtomicFile {
  public:
    AtomicFile() = default;
    ~AtomicFile() { abort(); }
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    // Opens "<finalPath>.part" for writing. `finalPath` must fit in kMaxPath. A final path that
    // is a device or a FIFO (/dev/null, a named pipe) is opened and written in place instead:
    // no temporary, commit() only closes, truncate() fails with -ESPIPE.
    int open(const char* finalPath) noexcept;
    int write(const void* data, std::size_t size) noexcept;
    // Cuts the temporary back to `size` bytes (a stream's last whole record) and goes on
    // writing from there.
    int truncate(off_t size) noexcept;
    // Closes (fsync first when `sync`) and renames the temporary onto the final path. On an
    // fsync or close error the temporary is removed, unless `keepOnError`: then it is still
    // renamed (a stream keeps what it holds) and the error is returned.
    int commit(bool sync, bool keepOnError = false) noexcept;
    // Closes and removes the temporary, if one is open.
    void abort() noexcept;
    bool isOpen() const { return fd_ >= 0; }
    // The bytes the open file holds (fstat's size; 0 for a device or a FIFO, or when closed):
    // what an encoder that writes the descriptor itself (PNG, EXR) wrote.
    std::int64_t size() const noexcept;
    int fd() const { return fd_; }
    const char* tempPath() const { return temp_; }

    static constexpr std::size_t kMaxPath = 4096;

  private:
    int fd_ = -1;
    bool direct_ = false;  // writing the final path in place (a device or a FIFO)
    char final_[kMaxPath] = {};
    char temp_[kMaxPath + 8] = {};
};

}  // namespace nvs::drivers
