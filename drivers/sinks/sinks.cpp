#include "drivers/sinks/sinks.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>

#include "drivers/sinks/glyphs.h"
#include "sim/core/error.h"
#include "sim/core/units.h"
#include "sim/io/png.h"
#include "sim/io/pnm.h"

namespace nvs::drivers {

namespace {

const char* stateName(SinkState s) {
    switch (s) {
        case SinkState::Open:
            return "open";
        case SinkState::Failed:
            return "failed";
        case SinkState::Closed:
            return "closed";
    }
    return "?";
}

// Counts scaled from `bits` to 16 bits (a left shift): full scale maps to full scale.
inline std::uint16_t to16(std::uint16_t v, int bits) {
    return bits >= 16 ? v : static_cast<std::uint16_t>(v << (16 - bits));
}
inline unsigned char to8(std::uint16_t v, int bits) {
    return static_cast<unsigned char>(bits <= 8 ? v << (8 - bits) : v >> (bits - 8));
}

void checkSize(int width, int height, const std::string& what) {
    if (width <= 0 || height <= 0) throw SetupError(what + ": image size must be positive");
}

}  // namespace

std::string describe(const char* name, SinkState state, const SinkCounters& c) {
    char buf[512];
    std::snprintf(buf, sizeof buf, "%s: %s, frames %lld, errors %lld, bytes %lld%s%s", name,
                  stateName(state), static_cast<long long>(c.frames),
                  static_cast<long long>(c.errors), static_cast<long long>(c.bytes),
                  c.lastErrno != 0 ? ", last error: " : "",
                  c.lastErrno != 0 ? std::strerror(c.lastErrno) : "");
    return buf;
}

void makeOutputDir(const std::string& dir, const std::string& what) {
    std::error_code ec;
    std::filesystem::create_directories(dir, ec);
    if (ec || !std::filesystem::is_directory(dir)) {
        throw SetupError(what + ": cannot create directory '" + dir + "': " + ec.message());
    }
    // A folder that exists but cannot take a file (read-only, no permission) fails here, at
    // setup, not on the first frame.
    char probe[AtomicFile::kMaxPath + 32];
    std::snprintf(probe, sizeof probe, "%s/.nvstim-probe-%d", dir.c_str(),
                  static_cast<int>(::getpid()));
    const int fd = ::open(probe, O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, 0644);
    if (fd < 0) {
        throw SetupError(what + ": cannot write in '" + dir + "': " + std::strerror(errno));
    }
    ::close(fd);
    ::unlink(probe);
}

// ---- y4m ---------------------------------------------------------------------------------------

namespace {
// The YUV4MPEG2 interlacing tag (mjpegtools yuv4mpeg(5): Ip progressive, It top field first,
// Ib bottom field first).
const char* y4mInterlace(msg::FieldOrder order) {
    switch (order) {
        case msg::FieldOrder::TopFirst:
            return "It";
        case msg::FieldOrder::BottomFirst:
            return "Ib";
        case msg::FieldOrder::Progressive:
            break;
    }
    return "Ip";
}
}  // namespace

Y4mSink::Y4mSink(const std::string& path, int width, int height, int bits, msg::FrameRate rate,
                 msg::FieldOrder order, PixelAspect aspect)
    : name_("y4m:" + path),
      toStdout_(path == "-"),
      width_(width),
      height_(height),
      bits_(bits),
      wide_(bits > 8) {
    checkSize(width, height, name_);
    const std::size_t px = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    buffer_.resize(6 + px * (wide_ ? 2 : 1));
    std::memcpy(buffer_.data(), "FRAME\n", 6);
    header_ = "YUV4MPEG2 W" + std::to_string(width) + " H" + std::to_string(height) + " F" +
              std::to_string(rate.num) + ":" + std::to_string(rate.den) + " " +
              y4mInterlace(order) + " A" + std::to_string(aspect.num) + ":" +
              std::to_string(aspect.den) + " " + (wide_ ? "Cmono16" : "Cmono") + "\n";
    const int rc = toStdout_ ? 0 : file_.open(path.c_str());
    if (rc != 0) throw SetupError(name_ + ": cannot open: " + std::strerror(-rc));
    out_.attach(toStdout_ ? STDOUT_FILENO : file_.fd());
}

Y4mSink::~Y4mSink() {
    close();
}

int Y4mSink::fail(int rc) noexcept {
    ++counters_.errors;
    counters_.lastErrno = -rc;
    state_ = SinkState::Failed;
    if (toStdout_) return rc;
    // Keep what was written: cut the file back to its last whole frame (a valid stream), or
    // remove it when it holds none.
    if (counters_.frames == 0 || file_.truncate(whole_) != 0) file_.abort();
    return rc;
}

int Y4mSink::write(const msg::OutputFrame& frame) noexcept {
    if (state_ != SinkState::Open) {
        ++counters_.errors;
        return counters_.lastErrno != 0 ? -counters_.lastErrno : -EBADF;
    }
    unsigned char* dst = buffer_.data() + 6;
    for (int y = 0; y < height_; ++y) {
        const std::uint16_t* row = frame.counts.row(y);
        if (wide_) {
            for (int x = 0; x < width_; ++x) {
                const std::uint16_t v = to16(row[x], bits_);
                *dst++ = static_cast<unsigned char>(v & 0xff);  // little-endian
                *dst++ = static_cast<unsigned char>(v >> 8);
            }
        } else {
            for (int x = 0; x < width_; ++x)
                *dst++ = to8(row[x], bits_);
        }
    }
    if (!headerWritten_) {
        const int rc = out_.write(header_.data(), header_.size());
        if (rc != 0) return fail(rc);
        headerWritten_ = true;
        counters_.bytes += static_cast<std::int64_t>(header_.size());
        whole_ += static_cast<off_t>(header_.size());
    }
    const int rc = out_.write(buffer_.data(), buffer_.size());
    if (rc != 0) return fail(rc);
    ++counters_.frames;
    counters_.bytes += static_cast<std::int64_t>(buffer_.size());
    whole_ += static_cast<off_t>(buffer_.size());
    return 0;
}

int Y4mSink::close() noexcept {
    if (state_ == SinkState::Closed) return 0;
    const bool wasFailed = state_ == SinkState::Failed;
    if (!wasFailed) state_ = SinkState::Closed;
    if (toStdout_ || !file_.isOpen()) return 0;
    // A failed stream is kept up to its last whole frame (fail() cut it there).
    const int rc = file_.commit(true, true);
    if (rc != 0) {
        ++counters_.errors;
        counters_.lastErrno = -rc;
        state_ = SinkState::Failed;
    }
    return rc;
}

// ---- PGM sequence ----------------------------------------------------------------------------

PgmSequenceSink::PgmSequenceSink(const std::string& dir, int width, int height, int bits)
    : name_("pgm:" + dir), dir_(dir), width_(width), height_(height), bits_(bits) {
    checkSize(width, height, name_);
    if (bits < 1 || bits > 16) throw SetupError(name_ + ": bits must be 1..16");
    makeOutputDir(dir, name_);
    buffer_.resize(io::pgmFileBytes(width, height, maxValue()));
}

int PgmSequenceSink::write(const msg::OutputFrame& frame) noexcept {
    if (state_ == SinkState::Closed) return -EBADF;
    if (frame.counts.width() != width_ || frame.counts.height() != height_) return -EINVAL;
    // The counts as they are, maximum value 2^bits - 1 (sim/io/pnm.h).
    const std::size_t size = io::encodePgm(frame.counts, maxValue(), buffer_.data());
    char path[AtomicFile::kMaxPath];
    std::snprintf(path, sizeof path, "%s/%06lld.pgm", dir_.c_str(),
                  static_cast<long long>(frame.tick));
    int rc = file_.open(path);
    if (rc == 0) rc = file_.write(buffer_.data(), size);
    if (rc == 0) rc = file_.commit(false);
    if (rc != 0) {
        file_.abort();
        ++counters_.errors;
        counters_.lastErrno = -rc;
        return rc;
    }
    ++counters_.frames;
    counters_.bytes += static_cast<std::int64_t>(size);
    return 0;
}

int PgmSequenceSink::close() noexcept {
    state_ = SinkState::Closed;
    return 0;
}

// ---- PNG sequence ----------------------------------------------------------------------------

PngSequenceSink::PngSequenceSink(const std::string& dir, int width, int height, int bits)
    : name_("png:" + dir), dir_(dir), width_(width), height_(height), bits_(bits) {
    checkSize(width, height, name_);
    makeOutputDir(dir, name_);
    buffer_.resize(static_cast<std::size_t>(width) * static_cast<std::size_t>(height));
}

int PngSequenceSink::write(const msg::OutputFrame& frame) noexcept {
    if (state_ == SinkState::Closed) return -EBADF;
    for (int y = 0; y < height_; ++y) {
        const std::uint16_t* row = frame.counts.row(y);
        std::uint16_t* dst =
            &buffer_[static_cast<std::size_t>(y) * static_cast<std::size_t>(width_)];
        if (bits_ > 8) {
            for (int x = 0; x < width_; ++x)
                dst[x] = to16(row[x], bits_);
        } else {
            for (int x = 0; x < width_; ++x)
                dst[x] = to8(row[x], bits_);
        }
    }
    char path[AtomicFile::kMaxPath];
    std::snprintf(path, sizeof path, "%s/%06lld.png", dir_.c_str(),
                  static_cast<long long>(frame.tick));
    const ImageView<const std::uint16_t> img(buffer_.data(), width_, height_, width_);
    int rc = file_.open(path);
    if (rc == 0) rc = io::writePng(file_.fd(), img, bits_ > 8 ? 16 : 8, io::PngColour::Srgb);
    const std::int64_t bytes = file_.size();  // libpng wrote the descriptor itself
    if (rc == 0) rc = file_.commit(false);
    if (rc != 0) {
        file_.abort();
        ++counters_.errors;
        counters_.lastErrno = -rc;
        return rc;
    }
    ++counters_.frames;
    counters_.bytes += bytes;
    return 0;
}

int PngSequenceSink::close() noexcept {
    state_ = SinkState::Closed;
    return 0;
}

// ---- metadata ---------------------------------------------------------------------------------

MetaJsonlSink::MetaJsonlSink(const std::string& path)
    : name_("meta:" + path), toStdout_(path == "-"), line_(8192 + 3 * msg::kMaxTruthBoxes * 256) {
    const int rc = toStdout_ ? 0 : file_.open(path.c_str());
    if (rc != 0) throw SetupError(name_ + ": cannot open: " + std::strerror(-rc));
    out_.attach(toStdout_ ? STDOUT_FILENO : file_.fd());
}

MetaJsonlSink::~MetaJsonlSink() {
    close();
}

namespace {
// Adds a snprintf's count to len; false when it did not fit.
bool took(int n, std::size_t size, std::size_t& len) noexcept {
    if (n < 0 || len + static_cast<std::size_t>(n) >= size) return false;
    len += static_cast<std::size_t>(n);
    return true;
}
// `{…},{…}]` of the boxes at buf + len (the opening bracket already written); false when it does
// not fit. The class is [A-Za-z0-9_-] (the scene's rule), so it needs no escaping.
bool formatTruth(const msg::TruthBox* boxes, int count, char* buf, std::size_t size,
                 std::size_t& len) noexcept {
    for (int i = 0; i < count && i < msg::kMaxTruthBoxes; ++i) {
        const msg::TruthBox& b = boxes[i];
        const int n = std::snprintf(
            buf + len, size - len,
            "%s{\"id\":%d,\"class\":\"%.15s\",\"x_px\":%.3f,\"y_px\":%.3f,\"w_px\":%.3f,"
            "\"h_px\":%.3f,\"visible\":%.4f,\"truncated\":%s,\"range_m\":%.3f}",
            i > 0 ? "," : "", b.id, b.cls, static_cast<double>(b.x_px), static_cast<double>(b.y_px),
            static_cast<double>(b.w_px), static_cast<double>(b.h_px),
            static_cast<double>(b.visible), b.truncated ? "true" : "false",
            static_cast<double>(b.range_m));
        if (!took(n, size, len)) return false;
    }
    if (len + 1 >= size) return false;
    buf[len++] = ']';
    return true;
}
// `,"exposure_start_s":…,"exposure_end_s":…` and, for a rendered scene, `,"camera":{…}` (the
// pinhole and the scene-to-camera transform, msg::CameraGeometry) at buf + len.
bool formatExposure(double t_sample_s, double exposure_s, const msg::CameraGeometry& g, char* buf,
                    std::size_t size, std::size_t& len) noexcept {
    int n =
        std::snprintf(buf + len, size - len, ",\"exposure_start_s\":%.9f,\"exposure_end_s\":%.9f",
                      t_sample_s - 0.5 * exposure_s, t_sample_s + 0.5 * exposure_s);
    if (!took(n, size, len)) return false;
    if (!g.valid) return true;
    n = std::snprintf(buf + len, size - len,
                      ",\"camera\":{\"width\":%d,\"height\":%d,\"fx_px\":%.6f,\"fy_px\":%.6f,"
                      "\"cx_px\":%.3f,\"cy_px\":%.3f,\"R\":[%.12f,%.12f,%.12f,%.12f,%.12f,%.12f,"
                      "%.12f,%.12f,%.12f],\"t_m\":[%.9f,%.9f,%.9f]}",
                      g.width, g.height, g.fx_px, g.fy_px, g.cx_px, g.cy_px, g.R[0], g.R[1], g.R[2],
                      g.R[3], g.R[4], g.R[5], g.R[6], g.R[7], g.R[8], g.t_m[0], g.t_m[1], g.t_m[2]);
    return took(n, size, len);
}

// A rig's channel (msg::RigMeta): `,"channel":…,"rig":{…},"faults":{…}` at buf + len.
bool formatRig(const msg::RigMeta& r, char* buf, std::size_t size, std::size_t& len) noexcept {
    const int own = r.channel;
    const int count = std::min(r.channels, msg::kMaxChannels);
    if (!took(std::snprintf(buf + len, size - len,
                            ",\"channel\":\"%.15s\",\"rig\":{\"trigger_count\":%lld,\"channels\":[",
                            r.name[own], static_cast<long long>(r.triggerCount)),
              size, len))
        return false;
    for (int j = 0; j < count; ++j) {
        if (!took(std::snprintf(buf + len, size - len, "%s\"%.15s\"", j > 0 ? "," : "", r.name[j]),
                  size, len))
            return false;
    }
    if (!took(std::snprintf(buf + len, size - len, "],\"ground_z_m\":%.6f,\"ground_homography\":{",
                            r.groundZ_m),
              size, len))
        return false;
    bool first = true;
    for (int j = 0; j < count; ++j) {
        if (j == own || !r.valid[j]) continue;
        const double* h = r.H[j];
        if (!took(
                std::snprintf(buf + len, size - len,
                              "%s\"%.15s\":[%.12g,%.12g,%.12g,%.12g,%.12g,%.12g,%.12g,%.12g,%.12g]",
                              first ? "" : ",", r.name[j], h[0], h[1], h[2], h[3], h[4], h[5], h[6],
                              h[7], h[8]),
                size, len))
            return false;
        first = false;
    }
    return took(
        std::snprintf(buf + len, size - len,
                      "}},\"faults\":{\"skew_s\":%.9f,\"stamp_jitter_s\":%.9f,"
                      "\"dropped_before\":%lld,\"misregistration_deg\":[%.6f,%.6f,%.6f]}",
                      r.skew_s, r.stampJitter_s, static_cast<long long>(r.droppedBefore),
                      r.misregistration_rad[0] * kDegPerRad, r.misregistration_rad[1] * kDegPerRad,
                      r.misregistration_rad[2] * kDegPerRad),
        size, len);
}
}  // namespace

std::size_t MetaJsonlSink::format(const msg::OutputFrame& frame, char* buf,
                                  std::size_t size) noexcept {
    const msg::FrameMeta& m = *frame.meta;
    const msg::PlatformState& p = m.platform;  // as commanded
    const msg::FieldMeta& a = m.applied();     // gain and gate as the camera applied them
    // The stamps as reported: a rig channel's jitter fault added (its truth under "faults").
    const double jitter_s = m.rig.channel >= 0 ? m.rig.stampJitter_s : 0.0;
    int n = std::snprintf(
        buf, size,
        "{\"frame\":%lld,\"tick\":%lld,\"repeat\":%s,\"t_sample_s\":%.9f,\"utc_unix_s\":%.6f,"
        "\"exposure_s\":%.9g,\"pose\":{\"lat_deg\":%.9f,\"lon_deg\":%.9f,\"alt_m\":%.4f,"
        "\"yaw_deg\":%.6f,\"pitch_deg\":%.6f,\"roll_deg\":%.6f},\"gain_V\":%.6g,\"gate_s\":%.9g,"
        "\"gate_mode\":%d,\"agc\":%s,\"lamps\":%u,\"pose_from_telemetry\":%s,\"stale\":%s,"
        "\"truth\":[",
        static_cast<long long>(m.frame), static_cast<long long>(frame.tick),
        frame.repeat ? "true" : "false", m.t_sample_s + jitter_s, p.utc_unix_s, m.exposure_s,
        p.lat_deg, p.lon_deg, p.alt_m, p.yaw_rad * kDegPerRad, p.pitch_rad * kDegPerRad,
        p.roll_rad * kDegPerRad, a.gain_V, a.gate_s, static_cast<int>(p.gateMode),
        p.agc ? "true" : "false", p.lampMask, p.poseFromTelemetry ? "true" : "false",
        p.stale ? "true" : "false");
    if (n < 0 || static_cast<std::size_t>(n) >= size) return 0;
    std::size_t len = static_cast<std::size_t>(n);
    if (!formatTruth(m.truth, m.truthCount, buf, size, len)) return 0;
    if (!formatExposure(m.t_sample_s + jitter_s, m.exposure_s, m.camera, buf, size, len)) return 0;
    if (m.rig.channel >= 0 && !formatRig(m.rig, buf, size, len)) return 0;
    // Interlaced: each field's own exposure (the frame-level keys describe field 1).
    if (m.fieldCount == msg::kMaxFields) {
        if (!took(std::snprintf(buf + len, size - len, ",\"fields\":["), size, len)) return 0;
        for (int f = 0; f < msg::kMaxFields; ++f) {
            const msg::FieldMeta& fm = m.field[f];
            n = std::snprintf(buf + len, size - len,
                              "%s{\"t_sample_s\":%.9f,\"gain_V\":%.6g,\"gate_s\":%.9g,\"truth\":[",
                              f > 0 ? "," : "", fm.t_sample_s + jitter_s, fm.gain_V, fm.gate_s);
            if (!took(n, size, len)) return 0;
            if (!formatTruth(fm.truth, fm.truthCount, buf, size, len)) return 0;
            if (!formatExposure(fm.t_sample_s + jitter_s, m.exposure_s, fm.camera, buf, size, len))
                return 0;
            if (len + 1 >= size) return 0;
            buf[len++] = '}';
        }
        if (len + 1 >= size) return 0;
        buf[len++] = ']';
    }
    if (len + 2 >= size) return 0;
    buf[len++] = '}';
    buf[len++] = '\n';
    return len;
}

int MetaJsonlSink::write(const msg::OutputFrame& frame) noexcept {
    if (state_ != SinkState::Open) {
        ++counters_.errors;
        return counters_.lastErrno != 0 ? -counters_.lastErrno : -EBADF;
    }
    const std::size_t len = format(frame, line_.data(), line_.size());
    int rc = len == 0 ? -EOVERFLOW : 0;
    if (rc == 0) rc = out_.write(line_.data(), len);
    if (rc != 0) {
        ++counters_.errors;
        counters_.lastErrno = -rc;
        state_ = SinkState::Failed;
        // Whole lines only: cut a half-written line off (no line at all: remove the file).
        if (!toStdout_ && (counters_.frames == 0 || file_.truncate(whole_) != 0)) file_.abort();
        return rc;
    }
    ++counters_.frames;
    counters_.bytes += static_cast<std::int64_t>(len);
    whole_ += static_cast<off_t>(len);
    return 0;
}

int MetaJsonlSink::close() noexcept {
    if (state_ == SinkState::Closed) return 0;
    if (state_ == SinkState::Open) state_ = SinkState::Closed;
    if (toStdout_ || !file_.isOpen()) return 0;
    const int rc = file_.commit(true, true);
    if (rc != 0) {
        ++counters_.errors;
        counters_.lastErrno = -rc;
        state_ = SinkState::Failed;
    }
    return rc;
}

// ---- contact sheet ----------------------------------------------------------------------------

namespace {
constexpr int kSheetGap_px = 4;
}

ContactSheetSink::ContactSheetSink(const std::string& path, int width, int height, int bits,
                                   int cols, int rows, int shrink, std::int64_t frames,
                                   std::int64_t every)
    : name_("contact:" + path),
      path_(path),
      width_(width),
      height_(height),
      bits_(bits),
      cols_(cols),
      rows_(rows),
      shrink_(shrink),
      frames_(frames),
      every_(every) {
    checkSize(width, height, name_);
    // Each factor bounded before the product: cols · rows of two large ints overflows.
    if (cols < 1 || rows < 1 || cols > 64 || rows > 64 || cols * rows > 64)
        throw SetupError(name_ + ": cols x rows must be 1..64");
    if (shrink < 1 || shrink > 16) throw SetupError(name_ + ": shrink must be 1..16");
    if (frames_ <= 0 && every_ <= 0) {
        throw SetupError(name_ + ": the run's length is not known: give every=N");
    }
    tileW_ = width / shrink;
    tileH_ = height / shrink;
    // The label: one font pixel per 96 tile columns (1 to 4), in a strip of the glyphs' five
    // rows with one above and one below.
    labelScale_ = std::clamp(tileW_ / 96, 1, 4);
    labelH_ = (kGlyphHeight_px + 2) * labelScale_;
    sheetW_ = cols * tileW_ + (cols + 1) * kSheetGap_px;
    sheetH_ = rows * (tileH_ + labelH_) + (rows + 1) * kSheetGap_px;
    sheet_.assign(static_cast<std::size_t>(sheetW_) * static_cast<std::size_t>(sheetH_), 255);
    const auto parent = std::filesystem::path(path).parent_path();
    if (!parent.empty()) makeOutputDir(parent.string(), name_);
    // The sheet's temporary is created now: a path that cannot be written (a folder, no
    // permission, a read-only file system) fails the setup instead of the end of the run.
    std::error_code ec;
    if (std::filesystem::is_directory(path, ec)) {
        throw SetupError(name_ + ": '" + path + "' is a directory, not a PNG file");
    }
    const std::string temp = path_ + ".part";
    part_ = std::fopen(temp.c_str(), "wbx");
    if (part_ == nullptr && errno == EEXIST) {
        std::remove(temp.c_str());  // a leftover of an interrupted run
        part_ = std::fopen(temp.c_str(), "wbx");
    }
    if (part_ == nullptr) {
        throw SetupError(name_ + ": cannot create '" + temp + "': " + std::strerror(errno));
    }
}

ContactSheetSink::~ContactSheetSink() {
    if (part_ != nullptr) {
        std::fclose(part_);
        std::remove((path_ + ".part").c_str());
    }
}

std::int64_t ContactSheetSink::tickOfTile(int i) const noexcept {
    const int tiles = cols_ * rows_;
    if (every_ > 0) return static_cast<std::int64_t>(i) * every_;
    if (tiles == 1) return 0;
    // Evenly from the first to the last frame.
    return static_cast<std::int64_t>(
        std::llround(static_cast<double>(i) * static_cast<double>(frames_ - 1) /
                     static_cast<double>(tiles - 1)));
}

int ContactSheetSink::tileX(int i) const noexcept {
    return kSheetGap_px + (i % cols_) * (tileW_ + kSheetGap_px);
}

int ContactSheetSink::tileY(int i) const noexcept {
    return kSheetGap_px + (i / cols_) * (tileH_ + labelH_ + kSheetGap_px);
}

int ContactSheetSink::write(const msg::OutputFrame& frame) noexcept {
    if (state_ == SinkState::Closed) return -EBADF;
    if (next_ >= cols_ * rows_ || frame.tick < tickOfTile(next_)) return 0;
    const int tx = tileX(next_);
    const int ty = tileY(next_);
    const int n = shrink_ * shrink_;
    for (int y = 0; y < tileH_; ++y) {
        std::uint16_t* dst =
            &sheet_[static_cast<std::size_t>(ty + y) * static_cast<std::size_t>(sheetW_) +
                    static_cast<std::size_t>(tx)];
        for (int x = 0; x < tileW_; ++x) {
            int sum = 0;
            for (int dy = 0; dy < shrink_; ++dy) {
                const std::uint16_t* row = frame.counts.row(y * shrink_ + dy);
                for (int dx = 0; dx < shrink_; ++dx)
                    sum += to8(row[x * shrink_ + dx], bits_);
            }
            dst[x] = static_cast<std::uint16_t>((sum + n / 2) / n);
        }
    }
    // The label: the frame shown and its time (the tick where there is no metadata).
    char label[48];
    if (frame.meta != nullptr) {
        std::snprintf(label, sizeof label, "%lld %.3fs", static_cast<long long>(frame.meta->frame),
                      frame.meta->t_sample_s);
    } else {
        std::snprintf(label, sizeof label, "%lld", static_cast<long long>(frame.tick));
    }
    drawText(sheet_.data(), sheetW_, sheetH_, tx, labelY(next_), tx + tileW_, label, labelScale_,
             0);
    ++next_;
    ++counters_.frames;
    return 0;
}

int ContactSheetSink::close() noexcept {
    if (state_ == SinkState::Closed || part_ == nullptr) return 0;
    state_ = SinkState::Closed;
    const std::string temp = path_ + ".part";
    const ImageView<const std::uint16_t> img(sheet_.data(), sheetW_, sheetH_, sheetW_);
    // Every step checked: encoded, on disk, closed; only then renamed into place.
    int rc = io::writePng(fileno(part_), img, 8, io::PngColour::Srgb);
    if (rc == 0 && ::fsync(fileno(part_)) != 0) rc = -errno;
    struct stat st {};
    const std::int64_t bytes =
        ::fstat(fileno(part_), &st) == 0 ? static_cast<std::int64_t>(st.st_size) : 0;
    if (std::fclose(part_) != 0 && rc == 0) rc = errno != 0 ? -errno : -EIO;
    part_ = nullptr;
    if (rc == 0 && std::rename(temp.c_str(), path_.c_str()) != 0) rc = -errno;
    if (rc != 0) {
        std::remove(temp.c_str());
        ++counters_.errors;
        counters_.lastErrno = -rc;
        state_ = SinkState::Failed;
        return rc;
    }
    counters_.bytes += bytes;  // the PNG file's, not the samples'
    return 0;
}

}  // namespace nvs::drivers
