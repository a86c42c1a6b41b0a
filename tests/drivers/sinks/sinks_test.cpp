// File sinks write exactly the documented bytes, and a sink that fails leaves no file.
#include "drivers/sinks/sinks.h"

#include <fcntl.h>
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/resource.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <csignal>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <thread>

#include "sim/io/image_file.h"

namespace nvs::drivers {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

// The metadata line: an interlaced frame also lists each field's own exposure (time, gain,
// gate); a progressive one has no "fields" key. Both lines are whole JSON objects.
TEST(Sinks, MetaLineListsTheFieldsOfAnInterlacedFrame) {
    msg::FrameMeta meta;
    meta.frame = 3;
    meta.t_sample_s = 0.1;
    meta.fieldCount = 2;
    meta.field[0].t_sample_s = 0.0833333333;
    meta.field[0].gain_V = 5.5;
    meta.field[0].gate_s = 0.0;
    meta.field[1].t_sample_s = 0.1;
    meta.field[1].gain_V = 5.75;
    meta.field[1].gate_s = 1e-4;
    // Each field's own truth: a person half hidden and cut by the image's edge in field 0, a
    // little further on and whole in field 1 (the frame-level truth is field 1's).
    msg::TruthBox b0{7, 0.0f, 10.0f, 5.5f, 20.0f, 0.5f, 31.25f, true};
    std::memcpy(b0.cls, "person", sizeof "person");
    msg::TruthBox b1 = b0;
    b1.x_px = 1.5f;
    b1.visible = 1.0f;
    b1.truncated = false;
    meta.field[0].truthCount = 1;
    meta.field[0].truth[0] = b0;
    meta.field[1].truthCount = 1;
    meta.field[1].truth[0] = b1;
    meta.truthCount = 1;
    meta.truth[0] = b1;
    // 20-ms exposures; field 1's camera geometry (the frame's), field 0's left unknown.
    meta.exposure_s = 0.02;
    msg::CameraGeometry g;
    g.valid = true;
    g.width = 768;
    g.height = 494;
    g.fx_px = 2000.0;
    g.fy_px = 1692.3;
    g.cx_px = 384.0;
    g.cy_px = 247.0;
    const double R[9] = {0.0, 1.0, 0.0, 0.0, 0.0, -1.0, -1.0, 0.0, 0.0};
    std::copy(R, R + 9, g.R);
    g.t_m[0] = 1.5;
    g.t_m[1] = -2.25;
    g.t_m[2] = 10.0;
    meta.field[1].camera = g;
    meta.camera = g;
    msg::OutputFrame f;
    f.meta = &meta;
    char buf[8192];
    const std::size_t n = MetaJsonlSink::format(f, buf, sizeof buf);
    ASSERT_GT(n, 0u);
    const std::string line(buf, n);
    const std::string box0 =
        "{\"id\":7,\"class\":\"person\",\"x_px\":0.000,\"y_px\":10.000,\"w_px\":5.500,"
        "\"h_px\":20.000,\"visible\":0.5000,\"truncated\":true,\"range_m\":31.250}";
    const std::string box1 =
        "{\"id\":7,\"class\":\"person\",\"x_px\":1.500,\"y_px\":10.000,\"w_px\":5.500,"
        "\"h_px\":20.000,\"visible\":1.0000,\"truncated\":false,\"range_m\":31.250}";
    const std::string camera =
        ",\"camera\":{\"width\":768,\"height\":494,\"fx_px\":2000.000000,\"fy_px\":1692.300000,"
        "\"cx_px\":384.000,\"cy_px\":247.000,\"R\":[0.000000000000,1.000000000000,"
        "0.000000000000,0.000000000000,0.000000000000,-1.000000000000,-1.000000000000,"
        "0.000000000000,0.000000000000],\"t_m\":[1.500000000,-2.250000000,10.000000000]}";
    EXPECT_NE(
        line.find("\"truth\":[" + box1 +
                  "],\"exposure_start_s\":0.090000000,\"exposure_end_s\":0.110000000" + camera +
                  ",\"fields\":[{\"t_sample_s\":0.083333333,"
                  "\"gain_V\":5.5,\"gate_s\":0,\"truth\":[" +
                  box0 +
                  "],\"exposure_start_s\":0.073333333,\"exposure_end_s\":0.093333333},"
                  "{\"t_sample_s\":0.100000000,\"gain_V\":5.75,\"gate_s\":0.0001,"
                  "\"truth\":[" +
                  box1 + "],\"exposure_start_s\":0.090000000,\"exposure_end_s\":0.110000000" +
                  camera + "}]}\n"),
        std::string::npos)
        << line;
    meta.fieldCount = 1;
    const std::string one(buf, MetaJsonlSink::format(f, buf, sizeof buf));
    EXPECT_EQ(one.find("fields"), std::string::npos) << one;
    EXPECT_EQ(one.substr(one.size() - 4), "]}}\n");  // the camera block closes the line
    // Too small a buffer gives nothing rather than a cut line.
    meta.fieldCount = 2;
    EXPECT_EQ(MetaJsonlSink::format(f, buf, n - 1), 0u);
}

// The frame-level gain_V and gate_s are what the camera applied to the exposure completing the
// frame (field 1 when interlaced), not what the platform commanded; gate_mode and agc are the
// commands.
TEST(Sinks, MetaLineGivesTheAppliedGainAndGate) {
    msg::FrameMeta meta;
    meta.platform.gain_V = 4.0;  // commanded
    meta.platform.gate_s = 2e-3;
    meta.platform.gateMode = msg::GateMode::Gated;
    meta.fieldCount = 2;
    meta.field[0].t_sample_s = 0.0;
    meta.field[0].gain_V = 5.5;
    meta.field[0].gate_s = 1e-3;
    meta.field[1].t_sample_s = 0.02;
    meta.field[1].gain_V = 5.75;
    meta.field[1].gate_s = 1e-4;
    msg::OutputFrame f;
    f.meta = &meta;
    char buf[4096];
    std::string line(buf, MetaJsonlSink::format(f, buf, sizeof buf));
    EXPECT_NE(line.find("\"gain_V\":5.75,\"gate_s\":0.0001,\"gate_mode\":1,"), std::string::npos)
        << line;
    meta.fieldCount = 1;
    line.assign(buf, MetaJsonlSink::format(f, buf, sizeof buf));
    EXPECT_NE(line.find("\"gain_V\":5.5,\"gate_s\":0.001,\"gate_mode\":1,"), std::string::npos)
        << line;
}

// EXR files say what they hold, as `nvstim render` labels its files (nvstim.unit, which
// `nvstim sensor --in` reads): Lpe in NNNNNN.exr and the band radiance in NNNNNN.band.exr
// when the frame has both; the band radiance alone in NNNNNN.exr.
TEST(Sinks, ExrFilesCarryTheirUnit) {
    const fs::path dir = fs::temp_directory_path() / ("nvs_exr_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    ImageF lpe(4, 3), band(4, 3);
    lpe.fill(2.5e6f);
    band.fill(1.25e-7f);
    msg::FrameMeta meta;
    msg::OutputFrame f;
    f.meta = &meta;
    f.radiance = msg::RadianceFrame{lpe.cview(), band.cview()};
    f.tick = 2;
    ExrSequenceSink sink((dir / "both").string(), 4, 3);
    ASSERT_EQ(sink.write(f), 0);
    f.radiance = msg::RadianceFrame{{}, band.cview()};
    ExrSequenceSink bandOnly((dir / "band").string(), 4, 3);
    ASSERT_EQ(bandOnly.write(f), 0);
    f.radiance = msg::RadianceFrame{};
    EXPECT_LT(bandOnly.write(f), 0);  // nothing to write is an error, counted

    const io::RadianceFile pe = io::readRadiance(dir / "both" / "000002.exr");
    EXPECT_EQ(pe.unit, "pe/s/m2/sr");
    EXPECT_EQ(pe.image(3, 2), 2.5e6f);
    const io::RadianceFile l = io::readRadiance(dir / "both" / "000002.band.exr");
    EXPECT_EQ(l.unit, "W/m2/sr");
    EXPECT_EQ(l.image(0, 0), 1.25e-7f);
    const io::RadianceFile only = io::readRadiance(dir / "band" / "000002.exr");
    EXPECT_EQ(only.unit, "W/m2/sr");
    EXPECT_EQ(only.image(1, 1), 1.25e-7f);
    EXPECT_FALSE(fs::exists(dir / "band" / "000002.band.exr"));
    fs::remove_all(dir);
}

TEST(Sinks, PgmAndY4mBytesAreExact) {
    const fs::path dir = fs::temp_directory_path() / ("nvs_sinks_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    ImageU16 counts(3, 2);
    for (int y = 0; y < 2; ++y)
        for (int x = 0; x < 3; ++x)
            counts(x, y) = static_cast<std::uint16_t>(1000 * y + x);  // 10-bit values
    ImageF rad(3, 2);
    msg::FrameMeta meta;
    msg::OutputFrame f;
    f.meta = &meta;
    f.counts = counts.cview();
    f.radiance.band_W_m2_sr = rad.cview();
    f.bits = 10;
    f.tick = 7;
    {
        PgmSequenceSink pgm((dir / "pgm").string(), 3, 2, 10);
        ASSERT_EQ(pgm.write(f), 0);
        pgm.close();
        Y4mSink y4m((dir / "v.y4m").string(), 3, 2, 10, msg::FrameRate{30000, 1001});
        ASSERT_EQ(y4m.write(f), 0);
        EXPECT_FALSE(fs::exists(dir / "v.y4m"));  // only complete streams appear
        y4m.close();
    }
    const std::string pgm = slurp(dir / "pgm" / "000007.pgm");
    const std::string header = "P5\n3 2\n1023\n";
    ASSERT_EQ(pgm.size(), header.size() + 12);
    EXPECT_EQ(pgm.substr(0, header.size()), header);
    // 1001 = 0x03E9, big-endian.
    EXPECT_EQ(static_cast<unsigned char>(pgm[header.size() + 8]), 0x03);
    EXPECT_EQ(static_cast<unsigned char>(pgm[header.size() + 9]), 0xE9);
    const std::string y4m = slurp(dir / "v.y4m");
    const std::string yh = "YUV4MPEG2 W3 H2 F30000:1001 Ip A1:1 Cmono16\nFRAME\n";
    ASSERT_EQ(y4m.size(), yh.size() + 12);
    EXPECT_EQ(y4m.substr(0, yh.size()), yh);
    // 1001 << 6 = 64064 = 0xFA40, little-endian.
    EXPECT_EQ(static_cast<unsigned char>(y4m[yh.size() + 8]), 0x40);
    EXPECT_EQ(static_cast<unsigned char>(y4m[yh.size() + 9]), 0xFA);
    fs::remove_all(dir);
}

// An output path that is a FIFO or a device (a named pipe to a consumer, /dev/null) is written
// in place: a temporary renamed onto it would replace the node by a regular file (for root,
// /dev/null). Here a named pipe: the reader gets the stream, the node stays a FIFO and no
// temporary is left beside it.
TEST(Sinks, Y4mIntoANamedPipeWritesThroughAndLeavesTheNode) {
    const fs::path dir =
        fs::temp_directory_path() / ("nvs_sinks_fifo_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    const fs::path fifo = dir / "v.y4m";
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    // The read end first (non-blocking open: no writer yet), so that the sink's open for
    // writing does not wait; then blocking reads until the writer closes. Were the sink to
    // write a temporary instead, no writer would ever open the pipe and the reads end at once.
    const int rfd = ::open(fifo.c_str(), O_RDONLY | O_NONBLOCK);
    ASSERT_GE(rfd, 0);
    ImageU16 counts(4, 2);
    counts.fill(3);
    msg::FrameMeta meta;
    msg::OutputFrame f;
    f.meta = &meta;
    f.counts = counts.cview();
    f.bits = 8;
    std::string got;
    {
        Y4mSink sink(fifo.string(), 4, 2, 8, msg::FrameRate{30, 1});
        std::thread reader([&] {
            ::fcntl(rfd, F_SETFL, 0);
            char buf[256];
            for (ssize_t n; (n = ::read(rfd, buf, sizeof buf)) > 0;)
                got.append(buf, static_cast<std::size_t>(n));
        });
        EXPECT_EQ(sink.write(f), 0);
        EXPECT_EQ(sink.write(f), 0);
        EXPECT_EQ(sink.close(), 0);
        reader.join();
    }
    ::close(rfd);
    const std::string header = "YUV4MPEG2 W4 H2 F30:1 Ip A1:1 Cmono\n";
    EXPECT_EQ(got.size(), header.size() + 2 * (6 + 8));
    EXPECT_EQ(got.substr(0, header.size()), header);
    EXPECT_TRUE(fs::is_fifo(fifo));
    EXPECT_FALSE(fs::exists(dir / "v.y4m.part"));
    fs::remove_all(dir);
}

TEST(Sinks, UnwritablePathIsASetupError) {
    EXPECT_THROW(Y4mSink("/proc/nvs-no/v.y4m", 4, 4, 8, msg::FrameRate{}), std::exception);
    EXPECT_THROW(MetaJsonlSink("/proc/nvs-no/m.jsonl"), std::exception);
}

// Lowers RLIMIT_FSIZE for one scope (a full disk without root mounts: writes past the limit
// fail with EFBIG) and ignores SIGXFSZ, as `nvstim run` does.
class FileSizeLimit {
  public:
    explicit FileSizeLimit(rlim_t bytes) {
        getrlimit(RLIMIT_FSIZE, &old_);
        oldSig_ = std::signal(SIGXFSZ, SIG_IGN);
        rlimit r = old_;
        r.rlim_cur = bytes;
        setrlimit(RLIMIT_FSIZE, &r);
    }
    ~FileSizeLimit() {
        setrlimit(RLIMIT_FSIZE, &old_);
        std::signal(SIGXFSZ, oldSig_);
    }

  private:
    rlimit old_{};
    void (*oldSig_)(int) = nullptr;
};

// An EXR that cannot be written whole is never renamed into place (no 0-byte or truncated
// file), no temporary is left, and each failure is counted. Before: OpenEXR's destructor
// swallowed the failure and a truncated file was committed with "errors 0".
TEST(Sinks, ExrOnAFullDiskCommitsNothingAndCountsTheErrors) {
    const fs::path dir = fs::temp_directory_path() / ("nvs_exr_full_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    ImageF band(64, 48);
    band.fill(1e-6f);
    msg::FrameMeta meta;
    msg::OutputFrame f;
    f.meta = &meta;
    f.radiance = msg::RadianceFrame{{}, band.cview()};
    ExrSequenceSink sink(dir.string(), 64, 48);
    // No room at all, room for the header only, and for all but the last bytes (519 B whole).
    for (const rlim_t limit : {rlim_t{0}, rlim_t{300}, rlim_t{500}}) {
        FileSizeLimit lim(limit);
        EXPECT_LT(sink.write(f), 0) << limit;
        ++f.tick;
    }
    EXPECT_NE(sink.status().find("errors 3"), std::string::npos) << sink.status();
    EXPECT_NE(sink.status().find("File too large"), std::string::npos) << sink.status();
    for (const auto& e : fs::directory_iterator(dir))
        ADD_FAILURE() << "left behind: " << e.path() << " (" << fs::file_size(e.path()) << " B)";
    ASSERT_EQ(sink.write(f), 0);  // room again: written whole
    EXPECT_EQ(io::readRadiance(dir / "000003.exr").image(5, 5), 1e-6f);
    fs::remove_all(dir);
}

// Replaces stdout by the write end of a pipe for one scope.
class StdoutToPipe {
  public:
    StdoutToPipe() {
        std::fflush(stdout);
        saved_ = ::dup(STDOUT_FILENO);
        int p[2];
        EXPECT_EQ(::pipe(p), 0);
        read_ = p[0];
        ::dup2(p[1], STDOUT_FILENO);
        ::close(p[1]);
        oldPipe_ = std::signal(SIGPIPE, SIG_IGN);
    }
    ~StdoutToPipe() {
        ::dup2(saved_, STDOUT_FILENO);
        ::close(saved_);
        if (read_ >= 0) ::close(read_);
        std::signal(SIGPIPE, oldPipe_);
    }
    void closeReader() {
        ::close(read_);
        read_ = -1;
    }

  private:
    int saved_ = -1, read_ = -1;
    void (*oldPipe_)(int) = nullptr;
};

// y4m on stdout: a reader that stops reading blocks the write only until cancel() (a stop),
// and a reader that goes away (EPIPE) fails the sink.
TEST(Sinks, Y4mOnAPipeIsCancelledWhenBlockedAndFailsWhenTheReaderGoes) {
    ImageU16 counts(256, 256);
    msg::FrameMeta meta;
    msg::OutputFrame f;
    f.meta = &meta;
    f.counts = counts.cview();
    f.bits = 8;
    {
        StdoutToPipe pipe;
        Y4mSink sink("-", 256, 256, 8, msg::FrameRate{30, 1});
        std::thread stopper([&] {
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
            sink.cancel();
        });
        // 64 KiB of pipe: the first frame fits, a few more do not.
        int rc = 0;
        for (int i = 0; i < 8 && rc == 0; ++i)
            rc = sink.write(f);
        stopper.join();
        EXPECT_EQ(rc, -ECANCELED);
        EXPECT_TRUE(sink.failed());
    }
    {
        StdoutToPipe pipe;
        Y4mSink sink("-", 256, 256, 8, msg::FrameRate{30, 1});
        pipe.closeReader();
        EXPECT_EQ(sink.write(f), -EPIPE);
        EXPECT_TRUE(sink.failed());
        EXPECT_NE(sink.status().find("failed"), std::string::npos);
    }
}

// A y4m file whose disk fills keeps its whole frames: cut back to the last one, renamed into
// place at close.
TEST(Sinks, Y4mFileKeepsItsWholeFramesWhenTheDiskFills) {
    const fs::path dir = fs::temp_directory_path() / ("nvs_y4m_full_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    ImageU16 counts(32, 32);
    msg::FrameMeta meta;
    msg::OutputFrame f;
    f.meta = &meta;
    f.counts = counts.cview();
    f.bits = 8;
    const std::string header = "YUV4MPEG2 W32 H32 F30:1 Ip A1:1 Cmono\n";
    const std::size_t frame = 6 + 32 * 32;
    {
        Y4mSink sink((dir / "v.y4m").string(), 32, 32, 8, msg::FrameRate{30, 1});
        FileSizeLimit lim(header.size() + 3 * frame + 100);  // the 4th frame does not fit
        int written = 0;
        while (sink.write(f) == 0)
            ++written;
        EXPECT_EQ(written, 3);
        EXPECT_TRUE(sink.failed());
        EXPECT_NE(sink.close(), 0 - 1);
    }
    EXPECT_EQ(fs::file_size(dir / "v.y4m"), header.size() + 3 * frame);
    EXPECT_FALSE(fs::exists(dir / "v.y4m.part"));
    EXPECT_EQ(slurp(dir / "v.y4m").substr(0, header.size()), header);
    fs::remove_all(dir);
}

}  // namespace
}  // namespace nvs::drivers
