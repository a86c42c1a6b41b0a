#include "drivers/v4l2/v4l2.h"

#include <fcntl.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>

#include "sim/core/error.h"

namespace nvs::drivers {

// ---- formats -------------------------------------------------------------------------------

std::uint32_t fourcc(V4l2Format f) noexcept {
    switch (f) {
        case V4l2Format::Grey:
            return V4L2_PIX_FMT_GREY;
        case V4l2Format::Y16:
            return V4L2_PIX_FMT_Y16;
        case V4l2Format::Yuyv:
            return V4L2_PIX_FMT_YUYV;
    }
    return 0;
}

int bytesPerPixel(V4l2Format f) noexcept {
    return f == V4l2Format::Grey ? 1 : 2;
}

const char* formatName(V4l2Format f) noexcept {
    switch (f) {
        case V4l2Format::Grey:
            return "GREY";
        case V4l2Format::Y16:
            return "Y16";
        case V4l2Format::Yuyv:
            return "YUYV";
    }
    return "?";
}

bool parseV4l2Format(std::string_view text, V4l2Format* f) noexcept {
    if (text == "GREY") {
        *f = V4l2Format::Grey;
    } else if (text == "Y16") {
        *f = V4l2Format::Y16;
    } else if (text == "YUYV") {
        *f = V4l2Format::Yuyv;
    } else {
        return false;
    }
    return true;
}

std::string fourccText(std::uint32_t code) {
    std::string s(4, ' ');
    for (int i = 0; i < 4; ++i) {
        const char c = static_cast<char>((code >> (8 * i)) & 0xffu);
        s[static_cast<std::size_t>(i)] = (c >= 32 && c < 127) ? c : '?';
    }
    return s;
}

// ---- kernel system calls -------------------------------------------------------------------

int KernelV4l2Ops::open(const char* path, int flags) noexcept {
    int fd;
    do {
        fd = ::open(path, flags);
    } while (fd < 0 && errno == EINTR);
    return fd < 0 ? -errno : fd;
}

int KernelV4l2Ops::close(int fd) noexcept {
    return ::close(fd) < 0 ? -errno : 0;
}

int KernelV4l2Ops::ioctl(int fd, unsigned long request, void* arg) noexcept {
    int rc;
    do {
        rc = ::ioctl(fd, request, arg);
    } while (rc < 0 && errno == EINTR);
    return rc < 0 ? -errno : 0;
}

ssize_t KernelV4l2Ops::write(int fd, const void* data, std::size_t size) noexcept {
    ssize_t n;
    do {
        n = ::write(fd, data, size);
    } while (n < 0 && errno == EINTR);
    return n < 0 ? -errno : n;
}

void* KernelV4l2Ops::mmap(std::size_t length, int fd, off_t offset, int* err) noexcept {
    void* p = ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, offset);
    if (p == MAP_FAILED) {
        *err = -errno;
        return nullptr;
    }
    *err = 0;
    return p;
}

int KernelV4l2Ops::munmap(void* addr, std::size_t length) noexcept {
    return ::munmap(addr, length) < 0 ? -errno : 0;
}

// ---- capability ----------------------------------------------------------------------------

std::uint32_t V4l2Capability::deviceCaps() const noexcept {
    return (raw_.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? raw_.device_caps : raw_.capabilities;
}

namespace {

std::string fixedString(const std::uint8_t* s, std::size_t n) {
    std::size_t len = 0;
    while (len < n && s[len] != 0)
        ++len;
    return std::string(reinterpret_cast<const char*>(s), len);
}

// Errors after which the node is gone or unusable: stop talking to it.
bool deviceGone(int err) {
    return err == ENODEV || err == ENXIO || err == EIO || err == EBADF || err == EPIPE;
}

}  // namespace

std::string V4l2Capability::driver() const {
    return fixedString(raw_.driver, sizeof raw_.driver);
}

std::string V4l2Capability::card() const {
    return fixedString(raw_.card, sizeof raw_.card);
}

// ---- the wrapper ---------------------------------------------------------------------------

const char* stateName(V4l2State s) noexcept {
    switch (s) {
        case V4l2State::Closed:
            return "closed";
        case V4l2State::Open:
            return "open";
        case V4l2State::Configured:
            return "configured";
        case V4l2State::Streaming:
            return "streaming";
        case V4l2State::Failed:
            return "failed";
    }
    return "?";
}

int V4l2Output::open(const std::string& path) {
    close();
    path_ = path;
    const int fd = ops_.open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
    if (fd < 0) {
        counters_.lastErrno = -fd;
        message_ = "cannot open " + path + ": " + std::strerror(-fd);
        return fd;
    }
    fd_ = fd;
    v4l2_capability raw{};
    const int rc = ops_.ioctl(fd_, VIDIOC_QUERYCAP, &raw);
    if (rc < 0) {
        message_ = path + " is not a V4L2 device (VIDIOC_QUERYCAP: " + std::strerror(-rc) + ")";
        ops_.close(fd_);
        fd_ = -1;
        return rc;
    }
    cap_ = V4l2Capability(raw);
    if (!cap_.isVideoOutput()) {
        message_ =
            path + " (" + cap_.driver() + ", \"" + cap_.card() + "\") is not a video output device";
        ops_.close(fd_);
        fd_ = -1;
        return -EINVAL;
    }
    state_ = V4l2State::Open;
    return 0;
}

int V4l2Output::configure(int width, int height, V4l2Format format, V4l2Io io, int buffers) {
    if (state_ != V4l2State::Open) {
        message_ = "configure: device not open";
        return -EINVAL;
    }
    if (width <= 0 || height <= 0 || (format == V4l2Format::Yuyv && width % 2 != 0)) {
        message_ = "configure: bad size (YUYV needs an even width)";
        return -EINVAL;
    }
    const auto w = static_cast<std::uint32_t>(width);
    const auto h = static_cast<std::uint32_t>(height);
    const auto bpp = static_cast<std::uint32_t>(bytesPerPixel(format));
    // Step 1: ask for the format.
    v4l2_format req{};
    req.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    req.fmt.pix.width = w;
    req.fmt.pix.height = h;
    req.fmt.pix.pixelformat = fourcc(format);
    req.fmt.pix.field = field_;
    req.fmt.pix.bytesperline = w * bpp;
    req.fmt.pix.sizeimage = w * h * bpp;
    int rc = ops_.ioctl(fd_, VIDIOC_S_FMT, &req);
    if (rc < 0) {
        message_ = path_ + ": VIDIOC_S_FMT " + formatName(format) + " " + std::to_string(w) + "x" +
                   std::to_string(h) + ": " + std::strerror(-rc);
        return rc;
    }
    // Step 2: read it back. v4l2loopback 0.12 answers S_FMT with success while keeping the
    // format a previous writer set (ready_for_capture / keep_format): only G_FMT tells.
    v4l2_format got{};
    got.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    rc = ops_.ioctl(fd_, VIDIOC_G_FMT, &got);
    if (rc < 0) {
        message_ = path_ + ": VIDIOC_G_FMT: " + std::strerror(-rc);
        return rc;
    }
    active_ = got.fmt.pix;
    // A driver that does not report the field keeps the one asked for.
    if (active_.field == V4L2_FIELD_ANY) active_.field = field_;
    if (active_.width != w || active_.height != h || active_.pixelformat != fourcc(format)) {
        ++counters_.formatMismatches;
        message_ = path_ + ": asked for " + std::to_string(w) + "x" + std::to_string(h) + " " +
                   formatName(format) + " but the device kept " + std::to_string(active_.width) +
                   "x" + std::to_string(active_.height) + " " + fourccText(active_.pixelformat) +
                   " (v4l2loopback holds a format while a reader is open or with keep_format: "
                   "close the readers or reload the module)";
        return -EBUSY;
    }
    if (active_.bytesperline != 0 && active_.bytesperline != w * bpp) {
        message_ = path_ + ": device pads rows to " + std::to_string(active_.bytesperline) +
                   " bytes; only packed rows are written";
        return -EINVAL;
    }
    // Step 3: every frame is exactly w·h·bpp bytes. sizeimage may be larger (0.12 rounds it up
    // to whole pages) and must not be what we write: one write() is one frame.
    frameBytes_ = static_cast<std::size_t>(w) * h * bpp;
    if (active_.sizeimage != 0 && active_.sizeimage < frameBytes_) {
        message_ = path_ + ": sizeimage " + std::to_string(active_.sizeimage) +
                   " is smaller than one frame (" + std::to_string(frameBytes_) + " bytes)";
        return -EINVAL;
    }
    io_ = io;
    if (io == V4l2Io::Write) {
        if (!cap_.hasReadWrite()) {
            message_ = path_ + ": the device has no write() I/O; use io=mmap";
            return -EINVAL;
        }
        writeBuffer_.assign(frameBytes_, 0);
    } else {
        if (!cap_.hasStreaming()) {
            message_ = path_ + ": the device has no streaming I/O; use io=write";
            return -EINVAL;
        }
        v4l2_requestbuffers rb{};
        rb.count = static_cast<std::uint32_t>(std::clamp(buffers, 2, kMaxBuffers));
        rb.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        rb.memory = V4L2_MEMORY_MMAP;
        rc = ops_.ioctl(fd_, VIDIOC_REQBUFS, &rb);
        if (rc < 0) {
            message_ = path_ + ": VIDIOC_REQBUFS: " + std::strerror(-rc);
            return rc;
        }
        if (rb.count < 2) {
            message_ =
                path_ + ": VIDIOC_REQBUFS granted " + std::to_string(rb.count) + " buffers, need 2";
            return -ENOMEM;
        }
        nBuffers_ = std::min(static_cast<int>(rb.count), kMaxBuffers);
        for (int i = 0; i < nBuffers_; ++i) {
            v4l2_buffer b{};
            b.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
            b.memory = V4L2_MEMORY_MMAP;
            b.index = static_cast<std::uint32_t>(i);
            rc = ops_.ioctl(fd_, VIDIOC_QUERYBUF, &b);
            if (rc < 0) {
                message_ = path_ + ": VIDIOC_QUERYBUF: " + std::strerror(-rc);
                return rc;
            }
            if (b.length < frameBytes_) {
                message_ = path_ + ": buffer of " + std::to_string(b.length) +
                           " bytes is smaller than one frame";
                return -EINVAL;
            }
            int err = 0;
            void* p = ops_.mmap(b.length, fd_, static_cast<off_t>(b.m.offset), &err);
            if (p == nullptr) {
                message_ = path_ + ": mmap: " + std::strerror(-err);
                return err;
            }
            buffers_[i] = Mapped{p, b.length, false};
        }
    }
    state_ = V4l2State::Configured;
    message_.clear();
    return 0;
}

int V4l2Output::fail(int rc) noexcept {
    ++counters_.errors;
    counters_.lastErrno = -rc;
    if (deviceGone(-rc)) state_ = V4l2State::Failed;
    return rc;
}

int V4l2Output::dequeueOne() noexcept {
    v4l2_buffer b{};
    b.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
    b.memory = V4L2_MEMORY_MMAP;
    const int rc = ops_.ioctl(fd_, VIDIOC_DQBUF, &b);
    if (rc < 0) return rc;
    if (b.index < static_cast<std::uint32_t>(nBuffers_)) buffers_[b.index].queued = false;
    return static_cast<int>(b.index);
}

std::uint8_t* V4l2Output::acquire() noexcept {
    if (state_ == V4l2State::Failed) {
        ++counters_.errors;
        return nullptr;
    }
    if (state_ != V4l2State::Configured && state_ != V4l2State::Streaming) return nullptr;
    if (io_ == V4l2Io::Write) return writeBuffer_.data();
    current_ = -1;
    for (int i = 0; i < nBuffers_; ++i) {
        if (!buffers_[i].queued) {
            current_ = i;
            break;
        }
    }
    if (current_ < 0) {
        // Every buffer is with the driver: take back the oldest the consumer has finished.
        const int rc = dequeueOne();
        if (rc == -EAGAIN) {
            ++counters_.busy;
            return nullptr;
        }
        if (rc < 0) {
            fail(rc);
            return nullptr;
        }
        current_ = rc;
        if (current_ >= nBuffers_) {
            fail(-EINVAL);
            current_ = -1;
            return nullptr;
        }
    }
    return static_cast<std::uint8_t*>(buffers_[current_].addr);
}

int V4l2Output::submit(std::uint32_t sequence, std::int64_t timestamp_ns) noexcept {
    if (state_ != V4l2State::Configured && state_ != V4l2State::Streaming) {
        return fail(state_ == V4l2State::Failed ? -counters_.lastErrno : -EBADF);
    }
    if (io_ == V4l2Io::Write) {
        const ssize_t n = ops_.write(fd_, writeBuffer_.data(), frameBytes_);
        if (n == -EAGAIN) {
            ++counters_.busy;
            return 0;
        }
        if (n < 0) return fail(static_cast<int>(n));
        if (static_cast<std::size_t>(n) != frameBytes_) {
            ++counters_.shortWrites;
            return fail(-EIO);
        }
    } else {
        if (current_ < 0) return fail(-EINVAL);
        v4l2_buffer b{};
        b.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        b.memory = V4L2_MEMORY_MMAP;
        b.index = static_cast<std::uint32_t>(current_);
        b.bytesused = static_cast<std::uint32_t>(frameBytes_);
        b.field = active_.field;
        b.flags = V4L2_BUF_FLAG_TIMESTAMP_COPY;
        b.sequence = sequence;
        b.timestamp.tv_sec = static_cast<time_t>(timestamp_ns / 1000000000);
        b.timestamp.tv_usec = static_cast<suseconds_t>((timestamp_ns % 1000000000) / 1000);
        int rc = ops_.ioctl(fd_, VIDIOC_QBUF, &b);
        if (rc < 0) return fail(rc);
        buffers_[current_].queued = true;
        current_ = -1;
        if (state_ == V4l2State::Configured) {
            int type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
            rc = ops_.ioctl(fd_, VIDIOC_STREAMON, &type);
            if (rc < 0) return fail(rc);
        }
    }
    state_ = V4l2State::Streaming;
    ++counters_.frames;
    counters_.bytes += static_cast<std::int64_t>(frameBytes_);
    return 0;
}

void V4l2Output::close() noexcept {
    if (fd_ < 0) return;
    if (io_ == V4l2Io::Mmap && nBuffers_ > 0) {
        if (state_ == V4l2State::Streaming) {
            int type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
            ops_.ioctl(fd_, VIDIOC_STREAMOFF, &type);
        }
        for (int i = 0; i < nBuffers_; ++i) {
            if (buffers_[i].addr != nullptr) ops_.munmap(buffers_[i].addr, buffers_[i].length);
            buffers_[i] = Mapped{};
        }
        v4l2_requestbuffers rb{};
        rb.count = 0;
        rb.type = V4L2_BUF_TYPE_VIDEO_OUTPUT;
        rb.memory = V4L2_MEMORY_MMAP;
        ops_.ioctl(fd_, VIDIOC_REQBUFS, &rb);
        nBuffers_ = 0;
    }
    ops_.close(fd_);
    fd_ = -1;
    current_ = -1;
    if (state_ != V4l2State::Failed) state_ = V4l2State::Closed;
}

std::string V4l2Output::status() const {
    char buf[512];
    std::snprintf(
        buf, sizeof buf,
        "%s, %ux%u %s, %s, frames %lld, bytes %lld, busy %lld, errors %lld, short "
        "writes %lld, format mismatches %lld%s%s",
        stateName(state_), active_.width, active_.height, fourccText(active_.pixelformat).c_str(),
        io_ == V4l2Io::Write ? "write()" : "mmap", static_cast<long long>(counters_.frames),
        static_cast<long long>(counters_.bytes), static_cast<long long>(counters_.busy),
        static_cast<long long>(counters_.errors), static_cast<long long>(counters_.shortWrites),
        static_cast<long long>(counters_.formatMismatches),
        counters_.lastErrno != 0 ? ", last error: " : "",
        counters_.lastErrno != 0 ? std::strerror(counters_.lastErrno) : "");
    return buf;
}

// ---- the sink ------------------------------------------------------------------------------

V4l2Sink::V4l2Sink(std::unique_ptr<V4l2DeviceOps> ops, const std::string& path, int width,
                   int height, int bits, V4l2Format format, V4l2Io io, msg::FieldOrder order)
    : ops_(std::move(ops)),
      out_(*ops_),
      name_("v4l2:" + path),
      path_(path),
      width_(width),
      height_(height),
      format_(format),
      io_(io) {
    if (bits < 1 || bits > 16) throw SetupError(name_ + ": bits must be in 1..16");
    int rc = out_.open(path);
    if (rc < 0) throw SetupError(name_ + ": " + out_.message());
    out_.setField(order == msg::FieldOrder::TopFirst      ? V4L2_FIELD_INTERLACED_TB
                  : order == msg::FieldOrder::BottomFirst ? V4L2_FIELD_INTERLACED_BT
                                                          : V4L2_FIELD_NONE);
    rc = out_.configure(width, height, format, io);
    if (rc < 0) throw SetupError(name_ + ": " + out_.message());
    // Count → sample table: v = v_min + round(c·(v_max − v_min)/(2^bits − 1)).
    const double vMin = format == V4l2Format::Yuyv ? 16.0 : 0.0;
    const double vMax = format == V4l2Format::Yuyv  ? 235.0
                        : format == V4l2Format::Y16 ? 65535.0
                                                    : 255.0;
    const std::size_t n = std::size_t{1} << bits;
    lut_.resize(n);
    const double cMax = static_cast<double>(n - 1);
    for (std::size_t c = 0; c < n; ++c) {
        lut_[c] = static_cast<std::uint16_t>(
            vMin + std::nearbyint(static_cast<double>(c) * (vMax - vMin) / cMax));
    }
}

void V4l2Sink::convertRow(const std::uint16_t* counts, int width, V4l2Format format,
                          const std::uint16_t* lut, std::uint8_t* dst) noexcept {
    switch (format) {
        case V4l2Format::Grey:
            for (int x = 0; x < width; ++x)
                dst[x] = static_cast<std::uint8_t>(lut[counts[x]]);
            break;
        case V4l2Format::Y16:
            for (int x = 0; x < width; ++x) {
                const std::uint16_t v = lut[counts[x]];
                dst[2 * x] = static_cast<std::uint8_t>(v & 0xffu);  // little-endian
                dst[2 * x + 1] = static_cast<std::uint8_t>(v >> 8);
            }
            break;
        case V4l2Format::Yuyv:
            // Y0 U Y1 V per pixel pair; no colour: U = V = 128.
            for (int x = 0; x + 1 < width; x += 2) {
                dst[2 * x] = static_cast<std::uint8_t>(lut[counts[x]]);
                dst[2 * x + 1] = 128;
                dst[2 * x + 2] = static_cast<std::uint8_t>(lut[counts[x + 1]]);
                dst[2 * x + 3] = 128;
            }
            break;
    }
}

bool V4l2Sink::recover(double now_s) noexcept {
    if (out_.state() != V4l2State::Failed) return true;
    if (up_) {
        ++losses_;
        up_ = false;
        backoff_.lost(now_s);
    }
    if (!backoff_.due(now_s)) return false;
    ++reopenAttempts_;
    out_.close();
    if (out_.open(path_) < 0 || out_.configure(width_, height_, format_, io_) < 0) {
        out_.close();
        backoff_.failed(now_s);
        return false;
    }
    ++reopened_;
    backoff_.succeeded();
    up_ = true;
    return true;
}

int V4l2Sink::write(const msg::OutputFrame& frame) noexcept {
    if (!recover(frame.emit_s)) {
        ++lostFrames_;
        return -std::max(out_.counters().lastErrno, 1);
    }
    std::uint8_t* dst = out_.acquire();
    if (dst == nullptr) {
        // No buffer free (consumer behind: counted as busy, not an error) or a failed device.
        return out_.state() == V4l2State::Failed ? -std::max(out_.counters().lastErrno, 1) : 0;
    }
    const std::size_t rowBytes =
        static_cast<std::size_t>(width_) * static_cast<std::size_t>(bytesPerPixel(format_));
    const std::uint16_t maxCount = static_cast<std::uint16_t>(lut_.size() - 1);
    const int w = std::min(width_, frame.counts.width());
    const int h = std::min(height_, frame.counts.height());
    for (int y = 0; y < h; ++y) {
        const std::uint16_t* row = frame.counts.row(y);
        // Counts above the ADC range cannot occur from a camera stage; clamp rather than read
        // outside the table.
        bool inRange = true;
        for (int x = 0; x < w; ++x)
            inRange &= row[x] <= maxCount;
        if (inRange) {
            convertRow(row, w, format_, lut_.data(), dst + static_cast<std::size_t>(y) * rowBytes);
        } else {
            std::uint8_t* d = dst + static_cast<std::size_t>(y) * rowBytes;
            for (int x = 0; x < w; ++x) {
                const std::uint16_t c = std::min(row[x], maxCount);
                const std::uint16_t v = lut_[c];
                if (format_ == V4l2Format::Grey) {
                    d[x] = static_cast<std::uint8_t>(v);
                } else if (format_ == V4l2Format::Y16) {
                    d[2 * x] = static_cast<std::uint8_t>(v & 0xffu);
                    d[2 * x + 1] = static_cast<std::uint8_t>(v >> 8);
                } else {
                    d[2 * x] = static_cast<std::uint8_t>(v);
                    d[2 * x + 1] = 128;
                }
            }
        }
    }
    const std::int64_t ts_ns = frame.emitMonotonic_ns != 0
                                   ? frame.emitMonotonic_ns
                                   : static_cast<std::int64_t>(std::llround(frame.emit_s * 1e9));
    return out_.submit(static_cast<std::uint32_t>(frame.tick), ts_ns);
}

int V4l2Sink::close() noexcept {
    out_.close();
    return 0;
}

std::string V4l2Sink::status() const {
    return name_ + ": " + out_.status() + ", device lost " + std::to_string(losses_) +
           ", reopen attempts " + std::to_string(reopenAttempts_) + ", reopened " +
           std::to_string(reopened_) + ", frames lost " + std::to_string(lostFrames_) +
           (up_ ? "" : ", DEVICE LOST");
}

}  // namespace nvs::drivers
