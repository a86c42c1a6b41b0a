// OpenEXR sequence sink (see sinks.h): the file format is sim/io/exr.h's, which catches
// OpenEXR's exceptions and returns -errno, so nothing escapes into the frame loop.
#include <cerrno>
#include <cstdio>

#include "drivers/sinks/sinks.h"
#include "sim/core/error.h"
#include "sim/io/exr.h"

namespace nvs::drivers {

ExrSequenceSink::ExrSequenceSink(const std::string& dir, int width, int height)
    : name_("exr:" + dir), dir_(dir), width_(width), height_(height) {
    if (width <= 0 || height <= 0) throw SetupError(name_ + ": image size must be positive");
    makeOutputDir(dir, name_);
    // The header's attributes, their values set per frame.
    attributes_.strings = {{io::kExrUnit, ""}};
    attributes_.ints = {{"nvs_frame", 0}};
    attributes_.doubles = {{"nvs_t_sample_s", 0.0}};
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
    char path[AtomicFile::kMaxPath];
    std::snprintf(path, sizeof path, "%s/%06lld%s.exr", dir_.c_str(),
                  static_cast<long long>(frame.tick), suffix);
    attributes_.strings[0].second = unit;
    attributes_.ints[0].second = static_cast<int>(frame.meta->frame);
    attributes_.doubles[0].second = frame.meta->t_sample_s;
    int rc = file_.open(path);
    if (rc == 0) rc = io::writeExr(file_.fd(), file_.tempPath(), img, attributes_);
    const std::int64_t bytes = file_.size();  // OpenEXR wrote the descriptor itself
    if (rc == 0) rc = file_.commit(false);
    if (rc != 0) {
        file_.abort();
        return rc;
    }
    counters_.bytes += bytes;
    return 0;
}

int ExrSequenceSink::close() noexcept {
    state_ = SinkState::Closed;
    return 0;
}

}  // namespace nvs::drivers
