// OpenEXR sequence sink (see sinks.h). OpenEXR reports errors by exceptions; they are caught
// here and turned into -errno so nothing escapes into the frame loop.
#include <ImfChannelList.h>
#include <ImfDoubleAttribute.h>
#include <ImfFrameBuffer.h>
#include <ImfHeader.h>
#include <ImfIntAttribute.h>
#include <ImfOutputFile.h>
#include <ImfStandardAttributes.h>
#include <ImfStringAttribute.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <exception>

#include "drivers/sinks/sinks.h"
#include "sim/core/error.h"

namespace nvs::drivers {

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
    int rc = 0;
    try {
        Imf::Header header(width_, height_);
        header.channels().insert("Y", Imf::Channel(Imf::FLOAT));
        header.insert("nvstim.unit", Imf::StringAttribute(unit));
        header.insert("nvs_frame", Imf::IntAttribute(static_cast<int>(frame.meta->frame)));
        header.insert("nvs_t_sample_s", Imf::DoubleAttribute(frame.meta->t_sample_s));
        Imf::OutputFile file(temp, header);
        Imf::FrameBuffer fb;
        fb.insert("Y", Imf::Slice(Imf::FLOAT, reinterpret_cast<char*>(buffer_.data()),
                                  sizeof(float), sizeof(float) * static_cast<std::size_t>(width_)));
        file.setFrameBuffer(fb);
        file.writePixels(height_);
    } catch (const std::exception&) {
        rc = errno != 0 ? -errno : -EIO;
    }
    if (rc == 0 && std::rename(temp, path) != 0) rc = -errno;
    if (rc != 0) ::unlink(temp);
    return rc;
}

int ExrSequenceSink::close() noexcept {
    state_ = SinkState::Closed;
    return 0;
}

}  // namespace nvs::drivers
