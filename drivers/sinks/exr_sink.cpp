// OpenEXR sequence sink (see sinks.h). OpenEXR reports errors by exceptions; they are caught
// here and turned into -errno so nothing escapes into the frame loop.
#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIO.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <exception>
#include <stdexcept>

#include "drivers/sinks/sinks.h"
#include "sim/core/error.h"

namespace nvs::drivers {

namespace {

// An Imf::OStream on a file descriptor that remembers its first error. OpenEXR writes the line
// offset table in ~OutputFile and swallows what that throws (ImfOutputFile.cpp: "We cannot
// safely throw any exceptions from here"), so a failure there — a full disk — would otherwise
// pass unnoticed and a truncated file would be renamed into place. Writes go through writeAll.
class CheckedFdStream final : public Imf::OStream {
  public:
    CheckedFdStream(const char* name, int fd) : Imf::OStream(name), fd_(fd) {}
    void write(const char c[], int n) override {
        if (error_ != 0) throw std::runtime_error("earlier write failed");
        const int rc = writeAll(fd_, c, static_cast<std::size_t>(n));
        if (rc != 0) {
            error_ = -rc;
            throw std::runtime_error("write failed");
        }
        pos_ += static_cast<std::uint64_t>(n);
    }
    std::uint64_t tellp() override { return pos_; }
    void seekp(std::uint64_t pos) override {
        if (::lseek(fd_, static_cast<off_t>(pos), SEEK_SET) < 0) {
            if (error_ == 0) error_ = errno;
            throw std::runtime_error("seek failed");
        }
        pos_ = pos;
    }
    int error() const { return error_; }

  private:
    int fd_;
    std::uint64_t pos_ = 0;
    int error_ = 0;
};

}  // namespace

ExrSequenceSink::ExrSequenceSink(const std::string& dir, int width, int height)
    : name_("exr:" + dir), dir_(dir), width_(width), height_(height) {
    if (width <= 0 || height <= 0) throw SetupError(name_ + ": image size must be positive");
    makeOutputDir(dir, name_);
    buffer_.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
}

int ExrSequenceSink::write(const msg::OutputFrame& frame) noexcept {
    if (state_ == SinkState::Closed) return -EBADF;
    // The image the camera consumes is the primary file; the band radiance goes beside it
    // when both exist (as `nvstim render` writes OUT.exr and OUT.band.exr).
    const msg::RadianceFrame& r = frame.radiance;
    const bool lpe = !r.lpe_pe_s_m2_sr.empty();
    const bool band = !r.band_W_m2_sr.empty();
    int rc = 0;
    if (lpe) rc = writeImage(frame, r.lpe_pe_s_m2_sr, "", "pe/s/m2/sr");
    if (rc == 0 && band) rc = writeImage(frame, r.band_W_m2_sr, lpe ? ".band" : "", "W/m2/sr");
    if (rc == 0 && !lpe && !band) rc = -EINVAL;  // a frame without radiance: nothing to write
    if (rc != 0) {
        ++counters_.errors;
        counters_.lastErrno = -rc;
        return rc;
    }
    ++counters_.frames;
    return 0;
}

int ExrSequenceSink::writeImage(const msg::OutputFrame& frame, ImageView<const float> img,
                                const char* suffix, const char* unit) noexcept {
    if (img.width() != width_ || img.height() != height_) return -EINVAL;
    for (int y = 0; y < height_; ++y) {
        const float* row = img.row(y);
        std::copy(row, row + width_, buffer_.begin() + static_cast<std::ptrdiff_t>(y) * width_);
    }
    char path[AtomicFile::kMaxPath];
    char temp[AtomicFile::kMaxPath + 8];
    std::snprintf(path, sizeof path, "%s/%06lld%s.exr", dir_.c_str(),
                  static_cast<long long>(frame.tick), suffix);
    std::snprintf(temp, sizeof temp, "%s.part", path);
    const int fd = ::open(temp, O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
    if (fd < 0) return -errno;
    int rc = 0;
    {
        CheckedFdStream stream(temp, fd);
        try {
            Imf::Header header(width_, height_);
            header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
            header.insert("nvstim.unit", Imf::StringAttribute(unit));
            header.insert("nvs_frame", Imf::IntAttribute(static_cast<int>(frame.meta->frame)));
            header.insert("nvs_t_sample_s", Imf::DoubleAttribute(frame.meta->t_sample_s));
            Imf::OutputFile file(stream, header);
            Imf::FrameBuffer fb;
            fb.insert("Y",
                      Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(buffer_.data()), sizeof(float),
                                 sizeof(float) * static_cast<std::size_t>(width_)));
            file.setFrameBuffer(fb);
            file.writePixels(height_);
        } catch (const std::exception&) {
            rc = -EIO;
        }
        // ~OutputFile has written the offsets by now; the stream knows whether that failed.
        if (stream.error() != 0) rc = -stream.error();
    }
    if (::close(fd) != 0 && rc == 0) rc = -errno;
    if (rc == 0 && std::rename(temp, path) != 0) rc = -errno;
    if (rc != 0) ::unlink(temp);
    return rc;
}

int ExrSequenceSink::close() noexcept {
    state_ = SinkState::Closed;
    return 0;
}

}  // namespace nvs::drivers
