#pragma once
// File writing that leaves nothing corrupt behind (DESIGN §7 "nothing half-written"): a file
// is written under a temporary name beside its final path and renamed into place only when
// complete; on any error the temporary is removed. All calls return 0 or -errno.

#include <cstddef>
#include <string>

namespace nvs::drivers {

// write(2) until all bytes are out (retries EINTR and short writes). 0 or -errno.
int writeAll(int fd, const void* data, std::size_t size) noexcept;

class AtomicFile {
  public:
    AtomicFile() = default;
    ~AtomicFile() { abort(); }
    AtomicFile(const AtomicFile&) = delete;
    AtomicFile& operator=(const AtomicFile&) = delete;

    // Opens "<finalPath>.part" for writing. `finalPath` must fit in kMaxPath.
    int open(const char* finalPath) noexcept;
    int write(const void* data, std::size_t size) noexcept;
    // Closes (fsync first when `sync`) and renames the temporary onto the final path.
    int commit(bool sync) noexcept;
    // Closes and removes the temporary, if one is open.
    void abort() noexcept;
    bool isOpen() const { return fd_ >= 0; }

    static constexpr std::size_t kMaxPath = 4096;

  private:
    int fd_ = -1;
    char final_[kMaxPath] = {};
    char temp_[kMaxPath + 8] = {};
};

}  // namespace nvs::drivers
