#pragma once
// FakeV4l2Loopback: an in-memory v4l2loopback 0.12 output node for tests (test-only target
// nvs_drivers_v4l2_fake, built with NVS_BUILD_TESTS; fake_v4l2.cpp lists what it answers).

#include <linux/videodev2.h>
#include <sys/types.h>

#include <cerrno>
#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "drivers/v4l2/v4l2.h"

namespace nvs::drivers {

// An in-memory v4l2loopback 0.12 output node at `path`. Tests set its knobs, run the real
// V4l2Output against it and read what a reader would receive from `frames`.
class FakeV4l2Loopback final : public V4l2DeviceOps {
  public:
    struct Frame {
        std::vector<std::uint8_t> data;  // exactly the bytes written / bytesused
        std::uint32_t sequence = 0;
        std::int64_t timestamp_ns = 0;
        bool streamed = false;  // through MMAP buffers (else write())
    };

    explicit FakeV4l2Loopback(std::string path = "/dev/video9") : path_(std::move(path)) {}

    // Knobs.
    bool outputCapable = true;  // false: a capture-only node (QUERYCAP without VIDEO_OUTPUT)
    bool readWrite = true;
    bool streaming = true;
    std::size_t pageSize = 4096;
    bool stallConsumer = false;  // queued buffers are not taken (DQBUF → EAGAIN)
    int maxBuffers = 8;          // REQBUFS grants at most this many
    // 0.12's keep-format behaviour: the current format is held; S_FMT returns it unchanged.
    void holdFormat(std::uint32_t width, std::uint32_t height, std::uint32_t pixelformat);
    // From now on every call fails with -err (ENODEV: the device was removed).
    void unplug(int err = ENODEV) { unplugged_ = err; }
    // The device is back (module reloaded, gadget re-plugged): open() works again.
    void replug() { unplugged_ = 0; }
    // Takes every queued buffer (ends stallConsumer's backlog).
    void releaseConsumer();

    // What happened.
    std::vector<Frame> frames;
    std::vector<std::size_t> writeSizes;  // size of every write() call
    const v4l2_pix_format& format() const { return fmt_; }
    bool isStreaming() const { return streamOn_; }
    int openCount() const { return opens_; }
    int mappedCount() const { return mapped_; }

    int open(const char* path, int flags) noexcept override;
    int close(int fd) noexcept override;
    int ioctl(int fd, unsigned long request, void* arg) noexcept override;
    ssize_t write(int fd, const void* data, std::size_t size) noexcept override;
    void* mmap(std::size_t length, int fd, off_t offset, int* err) noexcept override;
    int munmap(void* addr, std::size_t length) noexcept override;

  private:
    static constexpr int kFd = 7;
    struct Buffer {
        std::vector<std::uint8_t> mem;
        std::uint32_t bytesused = 0;
        std::uint32_t sequence = 0;
        std::int64_t timestamp_ns = 0;
        bool queued = false;
        bool done = false;
    };
    void consume(int index);
    std::uint32_t bufferLength() const;

    std::string path_;
    bool isOpen_ = false;
    int opens_ = 0;
    int unplugged_ = 0;
    bool holdFormat_ = false;
    bool formatSet_ = false;
    v4l2_pix_format fmt_{};
    std::vector<Buffer> buffers_;
    std::deque<int> done_;
    bool streamOn_ = false;
    int mapped_ = 0;
};

}  // namespace nvs::drivers
