// FakeV4l2Loopback: the subset of v4l2loopback 0.12's output-side behaviour that V4l2Output
// relies on, answered at the ioctl level (test double; allocates freely).
//
//   QUERYCAP   VIDEO_OUTPUT | READWRITE | STREAMING | DEVICE_CAPS (knobs remove them)
//   S_FMT      GREY, Y16, YUYV; bytesperline = w·bpp; sizeimage = PAGE_ALIGN(bytesperline·h).
//              While a format is held (holdFormat) the call succeeds and returns the held
//              format unchanged, as 0.12 does when ready_for_capture. EBUSY while buffers exist.
//   G_FMT      the current format
//   write()    one call = one frame of the bytes given (at most sizeimage); EBUSY while
//              streaming
//   REQBUFS    MMAP only; count ≤ maxBuffers; 0 frees. QUERYBUF: length = sizeimage,
//              m.offset = index·length. mmap() maps by offset.
//   QBUF       recorded; while streaming the consumer takes it at once (a frame) and it becomes
//              ready for DQBUF, unless stallConsumer. DQBUF: EAGAIN when none is ready
//              (the node is non-blocking). STREAMON takes what was queued before it.

#include "drivers/v4l2/fake/fake_v4l2.h"

#include <cerrno>
#include <cstring>

namespace nvs::drivers {

namespace {

std::uint32_t bppOf(std::uint32_t pixelformat) {
    switch (pixelformat) {
        case V4L2_PIX_FMT_GREY:
            return 1;
        case V4L2_PIX_FMT_Y16:
        case V4L2_PIX_FMT_YUYV:
            return 2;
        default:
            return 0;
    }
}

}  // namespace

void FakeV4l2Loopback::holdFormat(std::uint32_t width, std::uint32_t height,
                                  std::uint32_t pixelformat) {
    fmt_ = v4l2_pix_format{};
    fmt_.width = width;
    fmt_.height = height;
    fmt_.pixelformat = pixelformat;
    fmt_.field = V4L2_FIELD_NONE;
    fmt_.bytesperline = width * bppOf(pixelformat);
    const auto page = static_cast<std::uint32_t>(pageSize);
    fmt_.sizeimage = (fmt_.bytesperline * height + page - 1) / page * page;
    holdFormat_ = true;
    formatSet_ = true;
}

std::uint32_t FakeV4l2Loopback::bufferLength() const {
    return fmt_.sizeimage;
}

void FakeV4l2Loopback::consume(int index) {
    Buffer& b = buffers_[static_cast<std::size_t>(index)];
    Frame f;
    f.data.assign(b.mem.begin(), b.mem.begin() + b.bytesused);
    f.sequence = b.sequence;
    f.timestamp_ns = b.timestamp_ns;
    f.streamed = true;
    frames.push_back(std::move(f));
    b.queued = false;
    b.done = true;
    done_.push_back(index);
}

void FakeV4l2Loopback::releaseConsumer() {
    stallConsumer = false;
    if (!streamOn_) return;
    for (std::size_t i = 0; i < buffers_.size(); ++i) {
        if (buffers_[i].queued) consume(static_cast<int>(i));
    }
}

int FakeV4l2Loopback::open(const char* path, int /*flags*/) noexcept {
    if (unplugged_ != 0) return -ENOENT;
    if (path_ != path) return -ENOENT;
    isOpen_ = true;
    ++opens_;
    return kFd;
}

int FakeV4l2Loopback::close(int fd) noexcept {
    if (fd != kFd || !isOpen_) return -EBADF;
    isOpen_ = false;
    streamOn_ = false;
    if (mapped_ == 0) buffers_.clear();
    done_.clear();
    return 0;
}

int FakeV4l2Loopback::ioctl(int fd, unsigned long request, void* arg) noexcept {
    if (unplugged_ != 0) return -unplugged_;
    if (fd != kFd || !isOpen_) return -EBADF;
    switch (request) {
        case VIDIOC_QUERYCAP: {
            auto* c = static_cast<v4l2_capability*>(arg);
            *c = v4l2_capability{};
            std::strncpy(reinterpret_cast<char*>(c->driver), "v4l2 loopback", sizeof c->driver - 1);
            std::strncpy(reinterpret_cast<char*>(c->card), "nvstim fake", sizeof c->card - 1);
            std::uint32_t caps = V4L2_CAP_VIDEO_CAPTURE;
            if (outputCapable) caps |= V4L2_CAP_VIDEO_OUTPUT;
            if (readWrite) caps |= V4L2_CAP_READWRITE;
            if (streaming) caps |= V4L2_CAP_STREAMING;
            c->device_caps = caps;
            c->capabilities = caps | V4L2_CAP_DEVICE_CAPS;
            c->version = 0x000c05;  // 0.12.5
            return 0;
        }
        case VIDIOC_S_FMT: {
            auto* f = static_cast<v4l2_format*>(arg);
            if (f->type != V4L2_BUF_TYPE_VIDEO_OUTPUT) return -EINVAL;
            if (holdFormat_) {
                f->fmt.pix = fmt_;  // success, old format: the trap the read-back catches
                return 0;
            }
            if (!buffers_.empty()) return -EBUSY;
            const std::uint32_t bpp = bppOf(f->fmt.pix.pixelformat);
            if (bpp == 0 || f->fmt.pix.width == 0 || f->fmt.pix.height == 0) return -EINVAL;
            fmt_ = v4l2_pix_format{};
            fmt_.width = f->fmt.pix.width;
            fmt_.height = f->fmt.pix.height;
            fmt_.pixelformat = f->fmt.pix.pixelformat;
            fmt_.field = V4L2_FIELD_NONE;
            fmt_.bytesperline = fmt_.width * bpp;
            const auto page = static_cast<std::uint32_t>(pageSize);
            fmt_.sizeimage = (fmt_.bytesperline * fmt_.height + page - 1) / page * page;
            formatSet_ = true;
            f->fmt.pix = fmt_;
            return 0;
        }
        case VIDIOC_G_FMT: {
            auto* f = static_cast<v4l2_format*>(arg);
            if (f->type != V4L2_BUF_TYPE_VIDEO_OUTPUT) return -EINVAL;
            if (!formatSet_) return -EINVAL;
            f->fmt.pix = fmt_;
            return 0;
        }
        case VIDIOC_REQBUFS: {
            auto* r = static_cast<v4l2_requestbuffers*>(arg);
            if (!streaming || r->type != V4L2_BUF_TYPE_VIDEO_OUTPUT ||
                r->memory != V4L2_MEMORY_MMAP) {
                return -EINVAL;
            }
            if (streamOn_) return -EBUSY;
            buffers_.clear();
            done_.clear();
            if (r->count == 0) return 0;
            if (!formatSet_) return -EINVAL;
            const auto n = r->count < static_cast<std::uint32_t>(maxBuffers)
                               ? r->count
                               : static_cast<std::uint32_t>(maxBuffers);
            buffers_.resize(n);
            for (Buffer& b : buffers_)
                b.mem.assign(bufferLength(), 0);
            r->count = n;
            return 0;
        }
        case VIDIOC_QUERYBUF: {
            auto* b = static_cast<v4l2_buffer*>(arg);
            if (b->type != V4L2_BUF_TYPE_VIDEO_OUTPUT || b->index >= buffers_.size()) {
                return -EINVAL;
            }
            b->length = bufferLength();
            b->m.offset = b->index * bufferLength();
            b->memory = V4L2_MEMORY_MMAP;
            b->flags = buffers_[b->index].queued ? V4L2_BUF_FLAG_QUEUED : 0;
            return 0;
        }
        case VIDIOC_QBUF: {
            auto* b = static_cast<v4l2_buffer*>(arg);
            if (b->type != V4L2_BUF_TYPE_VIDEO_OUTPUT || b->memory != V4L2_MEMORY_MMAP ||
                b->index >= buffers_.size()) {
                return -EINVAL;
            }
            Buffer& buf = buffers_[b->index];
            if (buf.queued || b->bytesused > buf.mem.size()) return -EINVAL;
            buf.bytesused = b->bytesused;
            buf.sequence = b->sequence;
            buf.timestamp_ns = static_cast<std::int64_t>(b->timestamp.tv_sec) * 1000000000 +
                               static_cast<std::int64_t>(b->timestamp.tv_usec) * 1000;
            buf.queued = true;
            buf.done = false;
            if (streamOn_ && !stallConsumer) consume(static_cast<int>(b->index));
            return 0;
        }
        case VIDIOC_DQBUF: {
            auto* b = static_cast<v4l2_buffer*>(arg);
            if (b->type != V4L2_BUF_TYPE_VIDEO_OUTPUT) return -EINVAL;
            if (done_.empty()) return -EAGAIN;
            const int i = done_.front();
            done_.pop_front();
            Buffer& buf = buffers_[static_cast<std::size_t>(i)];
            buf.done = false;
            b->index = static_cast<std::uint32_t>(i);
            b->bytesused = buf.bytesused;
            b->sequence = buf.sequence;
            b->memory = V4L2_MEMORY_MMAP;
            return 0;
        }
        case VIDIOC_STREAMON: {
            if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_OUTPUT) return -EINVAL;
            if (buffers_.empty()) return -EINVAL;
            streamOn_ = true;
            if (!stallConsumer) {
                for (std::size_t i = 0; i < buffers_.size(); ++i) {
                    if (buffers_[i].queued) consume(static_cast<int>(i));
                }
            }
            return 0;
        }
        case VIDIOC_STREAMOFF: {
            if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_OUTPUT) return -EINVAL;
            streamOn_ = false;
            for (Buffer& b : buffers_)
                b.queued = b.done = false;
            done_.clear();
            return 0;
        }
        default:
            return -ENOTTY;
    }
}

ssize_t FakeV4l2Loopback::write(int fd, const void* data, std::size_t size) noexcept {
    if (unplugged_ != 0) return -unplugged_;
    if (fd != kFd || !isOpen_) return -EBADF;
    if (!readWrite || !formatSet_) return -EINVAL;
    if (streamOn_) return -EBUSY;
    writeSizes.push_back(size);
    const std::size_t n = size < fmt_.sizeimage ? size : fmt_.sizeimage;
    Frame f;
    const auto* p = static_cast<const std::uint8_t*>(data);
    f.data.assign(p, p + n);
    frames.push_back(std::move(f));
    return static_cast<ssize_t>(n);
}

void* FakeV4l2Loopback::mmap(std::size_t length, int fd, off_t offset, int* err) noexcept {
    if (unplugged_ != 0 || fd != kFd || !isOpen_) {
        *err = unplugged_ != 0 ? -unplugged_ : -EBADF;
        return nullptr;
    }
    const std::uint32_t len = bufferLength();
    if (len == 0 || offset < 0 || static_cast<std::uint64_t>(offset) % len != 0) {
        *err = -EINVAL;
        return nullptr;
    }
    const auto index = static_cast<std::size_t>(static_cast<std::uint64_t>(offset) / len);
    if (index >= buffers_.size() || length > len) {
        *err = -EINVAL;
        return nullptr;
    }
    ++mapped_;
    *err = 0;
    return buffers_[index].mem.data();
}

int FakeV4l2Loopback::munmap(void* /*addr*/, std::size_t /*length*/) noexcept {
    if (mapped_ > 0) --mapped_;
    return 0;
}

}  // namespace nvs::drivers
