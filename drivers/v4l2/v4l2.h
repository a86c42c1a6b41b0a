#pragma once
// V4L2 video output (docs/design.md §6), written for v4l2loopback 0.12.x and any other output
// device that speaks the same kernel ABI (linux/videodev2.h).
//
// Three layers, each testable alone:
//
//   V4l2DeviceOps   the five system calls the wrapper makes (open, close, ioctl, write, mmap/
//                   munmap). KernelV4l2Ops calls the kernel; FakeV4l2Loopback (fake/, a
//                   test-only target) is an in-memory device that answers the same ioctls
//                   with v4l2loopback 0.12's semantics, so the tests run the real wrapper
//                   code below against it.
//   V4l2Output      thin RAII wrapper: a state machine
//                     Closed → open() [QUERYCAP] → Open → configure() [S_FMT, G_FMT read-back,
//                     REQBUFS/QUERYBUF/mmap] → Configured → first frame [STREAMON] → Streaming
//                   with counters and status(). Calls return 0 or -errno.
//   V4l2Sink        msg::FrameSink: counts → GREY / Y16 / YUYV into the device's buffer.
//
// What v4l2loopback 0.12 does that the wrapper has to live with:
//   * S_FMT succeeds but silently keeps the old format while the device is "ready for capture"
//     (a writer set it before and a reader holds it, or the module's keep_format). The format
//     is therefore always read back with G_FMT and compared; a mismatch is reported, never
//     papered over.
//   * sizeimage is rounded up to whole pages (PAGE_ALIGN(bytesperline·height)). One write() is
//     one frame, so writes carry exactly width·height·bytes-per-pixel bytes, not sizeimage.
//   * A reader that goes away does not disturb the writer; a device that vanishes (module
//     unloaded, USB gadget gone) fails with ENODEV. Errors are counted; the sink reports them
//     to the loop, which stops only when [runtime] sink_errors = "stop". V4l2Sink then closes
//     the node and reopens and reconfigures it with backoff (0.1 s doubling to 5 s, on the
//     frames' emission clock), counting losses, attempts and reopens; the frames in between
//     are lost (counted) and the run goes on.
//
// Formats: GREY (8-bit, full range 0–255), Y16 (16-bit little-endian, full range), YUYV (4:2:2
// with Y in BT.601 studio range 16–235 and U = V = 128, what players assume for YUYV).
// Counts of `bits` bits are mapped to the format's range by a table built at setup:
//   v = round(c · (v_max − v_min)/(2^bits − 1)) + v_min.
// MMAP streaming carries a sequence number (the output tick) and a timestamp (CLOCK_MONOTONIC
// of emission, or the sim clock's emission time) in each queued buffer, flagged
// V4L2_BUF_FLAG_TIMESTAMP_COPY; write() mode cannot carry either (the driver stamps frames).

#include <linux/videodev2.h>
#include <sys/types.h>

#include <cstddef>
#include <cstdint>
#include <deque>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "sim/core/backoff.h"
#include "sim/msg/output.h"

namespace nvs::drivers {

// ---- formats -------------------------------------------------------------------------------

enum class V4l2Format : std::uint8_t { Grey, Y16, Yuyv };
enum class V4l2Io : std::uint8_t { Write, Mmap };

std::uint32_t fourcc(V4l2Format f) noexcept;
int bytesPerPixel(V4l2Format f) noexcept;
const char* formatName(V4l2Format f) noexcept;
// "GREY" | "Y16" | "YUYV" (case-sensitive, as V4L2 names them). False if unknown.
bool parseV4l2Format(std::string_view text, V4l2Format* f) noexcept;
// FourCC as text ("GREY", "Y16 ", ...), for messages.
std::string fourccText(std::uint32_t code);

// ---- system calls --------------------------------------------------------------------------

class V4l2DeviceOps {
  public:
    virtual ~V4l2DeviceOps() = default;
    // A file descriptor, or -errno.
    virtual int open(const char* path, int flags) noexcept = 0;
    virtual int close(int fd) noexcept = 0;
    // 0 or -errno (EINTR retried by the implementation).
    virtual int ioctl(int fd, unsigned long request, void* arg) noexcept = 0;
    // Bytes written, or -errno.
    virtual ssize_t write(int fd, const void* data, std::size_t size) noexcept = 0;
    // The mapping, or nullptr with -errno in *err.
    virtual void* mmap(std::size_t length, int fd, off_t offset, int* err) noexcept = 0;
    virtual int munmap(void* addr, std::size_t length) noexcept = 0;
};

// The kernel: open(2), ioctl(2), write(2), mmap(2) (PROT_READ|PROT_WRITE, MAP_SHARED).
class KernelV4l2Ops final : public V4l2DeviceOps {
  public:
    int open(const char* path, int flags) noexcept override;
    int close(int fd) noexcept override;
    int ioctl(int fd, unsigned long request, void* arg) noexcept override;
    ssize_t write(int fd, const void* data, std::size_t size) noexcept override;
    void* mmap(std::size_t length, int fd, off_t offset, int* err) noexcept override;
    int munmap(void* addr, std::size_t length) noexcept override;
};

// ---- capability ----------------------------------------------------------------------------

class V4l2Capability {
  public:
    V4l2Capability() = default;
    explicit V4l2Capability(const v4l2_capability& raw) : raw_(raw) {}
    // The capabilities of this device node (device_caps when the driver reports them).
    std::uint32_t deviceCaps() const noexcept;
    bool isVideoOutput() const noexcept { return (deviceCaps() & V4L2_CAP_VIDEO_OUTPUT) != 0; }
    bool hasReadWrite() const noexcept { return (deviceCaps() & V4L2_CAP_READWRITE) != 0; }
    bool hasStreaming() const noexcept { return (deviceCaps() & V4L2_CAP_STREAMING) != 0; }
    std::string driver() const;
    std::string card() const;
    const v4l2_capability& raw() const { return raw_; }

  private:
    v4l2_capability raw_{};
};

// ---- the wrapper ---------------------------------------------------------------------------

enum class V4l2State : std::uint8_t { Closed, Open, Configured, Streaming, Failed };
const char* stateName(V4l2State s) noexcept;

struct V4l2Counters {
    std::int64_t frames = 0;       // frames handed to the device
    std::int64_t bytes = 0;        // bytes written or queued
    std::int64_t errors = 0;       // failed writes / ioctls after setup
    std::int64_t busy = 0;         // frames not sent: no free buffer or EAGAIN (consumer behind)
    std::int64_t shortWrites = 0;  // write() that took fewer bytes than one frame
    std::int64_t formatMismatches = 0;  // S_FMT not honoured (read back differs)
    int lastErrno = 0;
};

class V4l2Output {
  public:
    static constexpr int kMaxBuffers = 8;

    explicit V4l2Output(V4l2DeviceOps& ops) : ops_(ops) {}
    ~V4l2Output() { close(); }
    V4l2Output(const V4l2Output&) = delete;
    V4l2Output& operator=(const V4l2Output&) = delete;

    // Opens the node (O_RDWR | O_NONBLOCK) and queries it. -ENOTTY if it is no V4L2 device,
    // -EINVAL if it is not a video output (message() says which).
    int open(const std::string& path);
    // S_FMT, G_FMT read-back (-EBUSY and formatMismatches + 1 when the device kept another
    // format), then the I/O method: write() needs V4L2_CAP_READWRITE; MMAP needs
    // V4L2_CAP_STREAMING and maps `buffers` buffers (REQBUFS may grant fewer, at least 2).
    int configure(int width, int height, V4l2Format format, V4l2Io io, int buffers = 4);
    // The field order to ask for at configure() (V4L2_FIELD_NONE unless set): interlaced
    // frames are V4L2_FIELD_INTERLACED_TB (top field first) or _BT. Every buffer carries the
    // field the device accepted.
    void setField(v4l2_field field) noexcept { field_ = field; }

    // Per frame, no allocation. acquire(): memory for the next frame (frameBytes() bytes), or
    // nullptr when none is free (the consumer is behind: counted in `busy`) or the device has
    // failed. submit(): sends it — write(2), or QBUF (and STREAMON on the first frame).
    std::uint8_t* acquire() noexcept;
    int submit(std::uint32_t sequence, std::int64_t timestamp_ns) noexcept;

    // STREAMOFF, unmaps, releases the buffers (REQBUFS 0) and closes. Safe to call twice.
    void close() noexcept;

    V4l2State state() const noexcept { return state_; }
    const V4l2Counters& counters() const noexcept { return counters_; }
    const V4l2Capability& capability() const { return cap_; }
    // The format read back from the device after configure().
    const v4l2_pix_format& activeFormat() const { return active_; }
    // width·height·bytes per pixel: the size of every write (≤ sizeimage).
    std::size_t frameBytes() const noexcept { return frameBytes_; }
    int bufferCount() const noexcept { return nBuffers_; }
    // The last setup problem, in words.
    const std::string& message() const { return message_; }
    std::string status() const;

  private:
    int fail(int rc) noexcept;
    int dequeueOne() noexcept;

    V4l2DeviceOps& ops_;
    int fd_ = -1;
    std::string path_;
    V4l2State state_ = V4l2State::Closed;
    v4l2_field field_ = V4L2_FIELD_NONE;  // asked for at configure()
    V4l2Io io_ = V4l2Io::Write;
    V4l2Capability cap_;
    v4l2_pix_format active_{};
    std::size_t frameBytes_ = 0;
    std::vector<std::uint8_t> writeBuffer_;  // write() mode
    struct Mapped {
        void* addr = nullptr;
        std::size_t length = 0;
        bool queued = false;
    };
    Mapped buffers_[kMaxBuffers];
    int nBuffers_ = 0;
    int current_ = -1;  // buffer handed out by acquire()
    V4l2Counters counters_;
    std::string message_;
};

// ---- the sink ------------------------------------------------------------------------------

class V4l2Sink final : public msg::FrameSink {
  public:
    // Opens and configures the device; throws SetupError (naming the spec) when it is absent,
    // not an output, refuses the format or keeps another one.
    V4l2Sink(std::unique_ptr<V4l2DeviceOps> ops, const std::string& path, int width, int height,
             int bits, V4l2Format format, V4l2Io io,
             msg::FieldOrder order = msg::FieldOrder::Progressive);
    ~V4l2Sink() override { close(); }
    const char* name() const noexcept override { return name_.c_str(); }
    int write(const msg::OutputFrame& frame) noexcept override;
    int close() noexcept override;
    std::string status() const override;
    const V4l2Output& output() const { return out_; }

    // Counts → device samples, as written (exposed for tests).
    static void convertRow(const std::uint16_t* counts, int width, V4l2Format format,
                           const std::uint16_t* lut, std::uint8_t* dst) noexcept;

    std::int64_t deviceLosses() const { return losses_; }
    std::int64_t reopened() const { return reopened_; }

  private:
    // The device failed (gone): reopen and reconfigure it when the backoff allows. True when
    // it is usable again. Runs on the sink's own thread; a reopen builds messages (allocates),
    // which only a lost device costs.
    bool recover(double now_s) noexcept;
    std::unique_ptr<V4l2DeviceOps> ops_;
    V4l2Output out_;
    std::string name_;
    std::string path_;
    int width_, height_;
    V4l2Format format_;
    V4l2Io io_;
    std::vector<std::uint16_t> lut_;  // count → sample value (2^bits entries)
    Backoff backoff_{kReconnectFirst_s, kReconnectMax_s};
    bool up_ = true;
    std::int64_t losses_ = 0;          // times the device was found gone
    std::int64_t reopenAttempts_ = 0;  // reopen + configure tries
    std::int64_t reopened_ = 0;        // of those, successful
    std::int64_t lostFrames_ = 0;      // frames not sent while it was gone
};

}  // namespace nvs::drivers
