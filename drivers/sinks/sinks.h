#pragma once
// File and pipe sinks (docs/design.md §6). Each is a FrameSink (sim/msg/output.h): configured and
// allocated at construction (throws SetupError for a bad path), then write() per frame
// returns 0 or -errno and counts; close() finishes the output.
//
//   Y4mSink          YUV4MPEG2, Cmono (8-bit) or Cmono16 (16-bit little-endian, counts scaled
//                    to the full 16 bits), to a file (temporary + rename at close) or stdout.
//                    A write that fails (full disk, EFBIG, I/O error) fails the sink and the
//                    file is cut back to its last whole frame, then renamed into place at
//                    close: a valid stream of every frame written before the fault (none: the
//                    file is removed). On stdout a vanished reader (EPIPE) fails the sink; a
//                    reader that stops reading blocks only this sink's thread, and cancel()
//                    ends such a wait (StreamWriter).
//   PgmSequenceSink  DIR/NNNNNN.pgm, binary P5, maxval 2^bits − 1 (16-bit big-endian above 8
//                    bits): the ADC counts exactly. Each file written whole, then renamed.
//   PngSequenceSink  DIR/NNNNNN.png, 8-bit gray, or 16-bit with counts scaled to 16 bits.
//   ExrSequenceSink  the frame's radiance as FLOAT channel "Y" (written through a checked
//                    stream: a file any of whose writes, or whose close, failed is removed,
//                    never renamed into place, and counted), each image labelled with its
//                    unit as `nvstim render` labels its files (header attribute nvstim.unit,
//                    read back by `nvstim sensor --in`): DIR/NNNNNN.exr the photoelectron
//                    radiance ("pe/s/m2/sr") when the frame has it, else the band radiance
//                    ("W/m2/sr"); DIR/NNNNNN.band.exr the band radiance when the frame has
//                    both. Attributes nvs_frame, nvs_t_sample_s as well.
//   MetaJsonlSink    one JSON object per emitted frame (file, temporary + rename, or stdout);
//                    on a failed write, as Y4mSink, the file keeps its whole lines:
//     {"frame","tick","repeat","t_sample_s","utc_unix_s","exposure_s",
//      "pose":{"lat_deg","lon_deg","alt_m","yaw_deg","pitch_deg","roll_deg"},
//      "gain_V","gate_s","gate_mode","agc","lamps","pose_from_telemetry","stale",
//      "truth":[{"id","x_px","y_px","w_px","h_px"}]}
//                    gain_V and gate_s are what the camera applied (FrameMeta::applied(), the
//                    exposure completing the frame); the other camera keys are as commanded.
//                    Interlaced frames add "fields":[{"t_sample_s","gain_V","gate_s"}, …].
// PNG and EXR files are encoded by libpng / OpenEXR, which allocate: those two sinks are for
// offline (sim clock) runs; the others allocate nothing per frame.

#include <cstdint>
#include <cstdio>
#include <string>
#include <vector>

#include "drivers/sinks/file_io.h"
#include "sim/io/exr.h"
#include "sim/msg/output.h"
#include "sim/msg/rate.h"

namespace nvs::drivers {

enum class SinkState { Open, Failed, Closed };

struct SinkCounters {
    std::int64_t frames = 0;  // frames written completely
    std::int64_t errors = 0;  // failed writes
    std::int64_t bytes = 0;
    int lastErrno = 0;
};

std::string describe(const char* name, SinkState state, const SinkCounters& c);

// The pixels' width over their height as a ratio (a y4m header's A tag; a camera with
// 11 × 13 µm cells: {11, 13}).
struct PixelAspect {
    int num = 1, den = 1;
};

class Y4mSink final : public msg::FrameSink {
  public:
    // path "-" is stdout. `bits` is the camera's ADC depth.
    Y4mSink(const std::string& path, int width, int height, int bits, msg::FrameRate rate,
            msg::FieldOrder order = msg::FieldOrder::Progressive, PixelAspect aspect = {});
    ~Y4mSink() override;
    const char* name() const noexcept override { return name_.c_str(); }
    int write(const msg::OutputFrame& frame) noexcept override;
    bool failed() const noexcept override { return state_ == SinkState::Failed; }
    void cancel() noexcept override { out_.cancel(); }
    int close() noexcept override;
    std::string status() const override { return describe(name_.c_str(), state_, counters_); }
    const SinkCounters& counters() const { return counters_; }

  private:
    int fail(int rc) noexcept;
    std::string name_;
    bool toStdout_ = false;
    AtomicFile file_;
    StreamWriter out_;
    off_t whole_ = 0;  // bytes of the header and the whole frames written
    int width_, height_, bits_;
    bool wide_;                          // 16-bit samples
    std::vector<unsigned char> buffer_;  // "FRAME\n" + one frame of samples
    std::string header_;
    bool headerWritten_ = false;
    SinkState state_ = SinkState::Open;
    SinkCounters counters_;
};

class PgmSequenceSink final : public msg::FrameSink {
  public:
    PgmSequenceSink(const std::string& dir, int width, int height, int bits);
    const char* name() const noexcept override { return name_.c_str(); }
    int write(const msg::OutputFrame& frame) noexcept override;
    int close() noexcept override;
    std::string status() const override { return describe(name_.c_str(), state_, counters_); }
    const SinkCounters& counters() const { return counters_; }

  private:
    int maxValue() const { return static_cast<int>((1u << bits_) - 1u); }
    std::string name_, dir_;
    int width_, height_, bits_;
    std::vector<unsigned char> buffer_;  // the file: header + samples
    AtomicFile file_;
    SinkState state_ = SinkState::Open;
    SinkCounters counters_;
};

class PngSequenceSink final : public msg::FrameSink {
  public:
    PngSequenceSink(const std::string& dir, int width, int height, int bits);
    const char* name() const noexcept override { return name_.c_str(); }
    int write(const msg::OutputFrame& frame) noexcept override;
    int close() noexcept override;
    std::string status() const override { return describe(name_.c_str(), state_, counters_); }

  private:
    std::string name_, dir_;
    int width_, height_, bits_;
    std::vector<std::uint16_t> buffer_;  // the samples at the file's depth (8 or 16 bit)
    AtomicFile file_;
    SinkState state_ = SinkState::Open;
    SinkCounters counters_;
};

class ExrSequenceSink final : public msg::FrameSink {
  public:
    ExrSequenceSink(const std::string& dir, int width, int height);
    const char* name() const noexcept override { return name_.c_str(); }
    msg::SinkInputs inputs() const noexcept override { return {false, true, false}; }
    int write(const msg::OutputFrame& frame) noexcept override;
    int close() noexcept override;
    std::string status() const override { return describe(name_.c_str(), state_, counters_); }

  private:
    // Writes one image to DIR/NNNNNN<suffix>.exr labelled `unit`. 0 or -errno.
    int writeImage(const msg::OutputFrame& frame, ImageView<const float> img, const char* suffix,
                   const char* unit) noexcept;
    std::string name_, dir_;
    int width_, height_;
    io::ExrAttributes attributes_;
    AtomicFile file_;
    SinkState state_ = SinkState::Open;
    SinkCounters counters_;
};

class MetaJsonlSink final : public msg::FrameSink {
  public:
    explicit MetaJsonlSink(const std::string& path);
    ~MetaJsonlSink() override;
    const char* name() const noexcept override { return name_.c_str(); }
    msg::SinkInputs inputs() const noexcept override { return {false, false, false}; }
    int write(const msg::OutputFrame& frame) noexcept override;
    bool failed() const noexcept override { return state_ == SinkState::Failed; }
    void cancel() noexcept override { out_.cancel(); }
    int close() noexcept override;
    std::string status() const override { return describe(name_.c_str(), state_, counters_); }
    const SinkCounters& counters() const { return counters_; }
    // Formats one record into buf (no allocation); returns its length, or 0 if it did not fit.
    static std::size_t format(const msg::OutputFrame& frame, char* buf, std::size_t size) noexcept;

  private:
    std::string name_;
    bool toStdout_ = false;
    AtomicFile file_;
    StreamWriter out_;
    off_t whole_ = 0;  // bytes of the whole lines written
    std::vector<char> line_;
    SinkState state_ = SinkState::Open;
    SinkCounters counters_;
};

// Creates DIR (and parents) at setup and checks that a file can be created in it (a temporary
// probe, removed at once); throws SetupError naming `what` on failure.
void makeOutputDir(const std::string& dir, const std::string& what);

// A contact sheet: `cols × rows` frames spread evenly over a run of `frames` frames (or every
// `every`-th frame when the length is not known), each shrunk by `shrink` (box filter), 8-bit,
// on a white grid, written as one PNG when the run closes. A glance at a run's content.
// Under each tile a white strip carries its label in black: the frame number and its time
// (metadata `frame` and `t_sample_s`, "12 0.400s"), drawn with a built-in 3 × 5 pixel font
// (drivers/sinks/glyphs.h) at labelScale() pixels per font pixel; the tile itself is untouched.
// The sheet's file is created at setup (as FILE.part, renamed at close): an unwritable path
// fails the setup, not the end of the run.
class ContactSheetSink final : public msg::FrameSink {
  public:
    ContactSheetSink(const std::string& path, int width, int height, int bits, int cols, int rows,
                     int shrink, std::int64_t frames, std::int64_t every);
    ~ContactSheetSink() override;
    ContactSheetSink(const ContactSheetSink&) = delete;
    ContactSheetSink& operator=(const ContactSheetSink&) = delete;
    const char* name() const noexcept override { return name_.c_str(); }
    int write(const msg::OutputFrame& frame) noexcept override;
    int close() noexcept override;
    std::string status() const override { return describe(name_.c_str(), state_, counters_); }
    // The tick that fills tile i (exposed for tests).
    std::int64_t tickOfTile(int i) const noexcept;
    // The layout (exposed for tests): tile i's top-left corner, the label's top-left corner
    // below it, the label's font scale, the sheet's size.
    int tileX(int i) const noexcept;
    int tileY(int i) const noexcept;
    int labelY(int i) const noexcept { return tileY(i) + tileH_ + labelScale_; }
    int labelScale() const noexcept { return labelScale_; }
    int sheetWidth() const noexcept { return sheetW_; }
    int sheetHeight() const noexcept { return sheetH_; }

  private:
    std::string name_, path_;
    int width_, height_, bits_, cols_, rows_, shrink_;
    int tileW_, tileH_, sheetW_, sheetH_;
    int labelScale_, labelH_;  // the font's scale; the strip's height (7 scaled font rows)
    std::int64_t frames_, every_;
    int next_ = 0;                      // next tile to fill
    std::vector<std::uint16_t> sheet_;  // 8-bit samples
    std::FILE* part_ = nullptr;         // FILE.part, opened at setup
    SinkState state_ = SinkState::Open;
    SinkCounters counters_;
};

}  // namespace nvs::drivers
