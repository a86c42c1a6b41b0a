// `nvstim render` and `nvstim sensor` with a thermal preset (issue 30, docs/bolometer.md, "The
// command line"): render → sensor gives the frame `nvstim run` gives (the same radiance, the same
// chain, seed, frame rate and start-up shutter correction); a render made for another camera —
// visible radiance into a thermal preset, a thermal render into an intensified one, another band,
// another size — is refused with one line and exit 2, and nothing is written.
#include <gtest/gtest.h>
#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <string>
#include <system_error>

#include "sim/io/exr.h"
#include "sim/io/image_file.h"
#include "tests/rt/cli/cli_run.h"

namespace nvs {
namespace {
namespace fs = std::filesystem;
using test::nvstim;
using test::WorkDir;

const fs::path kSource = NVS_SOURCE_DIR;
const fs::path kNight = kSource / "scenarios/thesis-nolight-lwir";

// Exit 2, one line on stderr naming `what`, and `out` not written.
void expectRefused(const test::CliRun& r, const std::string& what, const fs::path& out) {
    test::expectOneLineRefusal(r, what);
    EXPECT_FALSE(fs::exists(out));
}

// A radiance image of w × h, value v, with the given header strings.
fs::path writeRadiance(const fs::path& p, int w, int h, float v,
                       std::vector<std::pair<std::string, std::string>> strings) {
    ImageF img(w, h);
    img.fill(v);
    io::writeExr(p, img.cview(), {std::move(strings), {}, {}});
    return p;
}

// One render of the night's first frame, shared by the tests of this file run in one process;
// a folder per process, removed when it exits, since ctest runs the tests as processes side by
// side (with one folder, one test's fs::remove took the other's render away).
struct RenderDir {
    fs::path dir =
        fs::path(NVS_BINARY_DIR) / ("test-thermal-cli-render-" + std::to_string(::getpid()));
    ~RenderDir() {
        std::error_code ec;
        fs::remove_all(dir, ec);
    }
};

const fs::path& nightRender() {
    static const RenderDir folder;
    static const fs::path file = [] {
        fs::create_directories(folder.dir);
        const fs::path f = folder.dir / "night.exr";
        const auto r = nvstim("render " + kNight.string() + " --frame 0 --out " + f.string());
        EXPECT_EQ(r.status, 0) << r.err;
        return f;
    }();
    return file;
}

TEST(ThermalCli, RenderWritesTheBandRadianceNamingPresetAndBand) {
    const io::ExrImage exr = io::readExr(nightRender());
    EXPECT_EQ(exr.image.width(), 640);
    EXPECT_EQ(exr.image.height(), 512);
    EXPECT_EQ(exr.attribute("nvstim.unit"), "W/m2/sr");
    EXPECT_EQ(exr.attribute("nvstim.camera"), "boson-640");
    EXPECT_EQ(exr.attribute("nvstim.band"), "LWIR 7.5-13.5 um");
    EXPECT_FALSE(exr.attribute("nvstim.startup_W_m2_sr").empty());
    EXPECT_FALSE(fs::exists(fs::path(nightRender()).replace_extension(".band.exr")));
    // Planck's law over 7.5-13.5 µm (integrated apart from the code, in double precision):
    // 21.7 W m⁻² sr⁻¹ at 250 K, 55.5 at 300 K, 143.5 at 373 K. The September night's view is
    // grass, roofs and asphalt near the air's 288 K under a sky colder than 250 K: its mean lies
    // between the two; no pixel is as bright as boiling water or negative.
    double sum = 0.0;
    for (int y = 0; y < 512; ++y)
        for (int x = 0; x < 640; ++x) {
            const float v = exr.image(x, y);
            ASSERT_TRUE(v >= 0.0f && v < 143.5f) << x << "," << y << ": " << v;
            sum += static_cast<double>(v);
        }
    const double mean = sum / (640.0 * 512.0);
    EXPECT_GT(mean, 21.7);
    EXPECT_LT(mean, 55.5);
}

TEST(ThermalCli, RenderThenSensorGivesTheRunsFirstFrame) {
    WorkDir w;
    // The scenario runs its camera at 30 Hz (the preset's 60 Hz overridden) with seed 1.
    const auto run = nvstim("run " + kNight.string() +
                            " --clock sim --frames 1 --output pgm:" + (w.path / "run").string());
    ASSERT_EQ(run.status, 0) << run.err;
    const fs::path out = w.path / "sensor.pgm";
    const auto s =
        nvstim("sensor --in " + nightRender().string() +
               " --camera boson-640 --set frame_rate_Hz=30 --seed 1 --out " + out.string());
    ASSERT_EQ(s.status, 0) << s.err;
    EXPECT_NE(s.out.find("\"band\":\"LWIR 7.5-13.5 um\""), std::string::npos) << s.out;
    const io::CountsFile a = io::readCounts(w.path / "run/000000.pgm");
    const io::CountsFile b = io::readCounts(out);
    EXPECT_EQ(a.maxValue, 255);
    EXPECT_EQ(b.maxValue, 255);
    ASSERT_EQ(a.image.width(), b.image.width());
    ASSERT_EQ(a.image.height(), b.image.height());
    long long differ = 0, lo = 255, hi = 0;
    for (int y = 0; y < a.image.height(); ++y)
        for (int x = 0; x < a.image.width(); ++x) {
            differ += a.image(x, y) != b.image(x, y);
            lo = std::min<long long>(lo, b.image(x, y));
            hi = std::max<long long>(hi, b.image(x, y));
        }
    EXPECT_EQ(differ, 0);
    EXPECT_GT(hi - lo, 100);  // a picture, not a frozen or flat frame
}

// Later frames: the chain carries state (lag, drift, 1/f, the shutter's schedule), so the run's
// frame k is one `sensor` call over the renders of frames 0 … k.
TEST(ThermalCli, RenderPatternThenSensorGivesTheRunsFrames) {
    WorkDir w;
    const auto run = nvstim("run " + kNight.string() +
                            " --clock sim --frames 3 --output pgm:" + (w.path / "run").string());
    ASSERT_EQ(run.status, 0) << run.err;
    fs::create_directories(w.path / "r");
    for (int k = 0; k < 3; ++k) {
        char name[32];
        std::snprintf(name, sizeof name, "%06d.exr", k);
        const auto r = nvstim("render " + kNight.string() + " --frame " + std::to_string(k) +
                              " --out " + (w.path / "r" / name).string());
        ASSERT_EQ(r.status, 0) << r.err;
    }
    const auto s = nvstim("sensor --in " + (w.path / "r/{frame:06d}.exr").string() +
                          " --camera boson-640 --set frame_rate_Hz=30 --seed 1 --out " +
                          (w.path / "s{frame:06d}.pgm").string());
    ASSERT_EQ(s.status, 0) << s.err;
    for (int k = 0; k < 3; ++k) {
        char a[32], b[32];
        std::snprintf(a, sizeof a, "run/%06d.pgm", k);
        std::snprintf(b, sizeof b, "s%06d.pgm", k);
        const io::CountsFile x = io::readCounts(w.path / a), y = io::readCounts(w.path / b);
        ASSERT_EQ(x.image.width(), y.image.width());
        long long differ = 0;
        for (int yy = 0; yy < x.image.height(); ++yy)
            for (int xx = 0; xx < x.image.width(); ++xx)
                differ += x.image(xx, yy) != y.image(xx, yy);
        EXPECT_EQ(differ, 0) << "frame " << k;
    }
}

TEST(ThermalCli, SensorWritesRawCountsAsExr) {
    WorkDir w;
    const fs::path out = w.path / "raw.exr";
    const auto s = nvstim("sensor --in " + nightRender().string() +
                          " --camera boson-640 --frames 2 --out " + out.string());
    ASSERT_EQ(s.status, 0) << s.err;
    const io::ExrImage raw = io::readExr(out);
    EXPECT_EQ(raw.attribute("nvstim.unit"), "DC");
    float lo = 1e9f, hi = -1.0f;
    for (int y = 0; y < raw.image.height(); ++y)
        for (int x = 0; x < raw.image.width(); ++x) {
            lo = std::min(lo, raw.image(x, y));
            hi = std::max(hi, raw.image(x, y));
        }
    EXPECT_GE(lo, 0.0f);
    EXPECT_LE(hi, 16383.0f);  // the preset's 14-bit ADC
    EXPECT_GT(hi - lo, 50.0f);
}

TEST(ThermalCli, VisibleRenderIntoThermalPresetIsRefused) {
    WorkDir w;
    const fs::path pe =
        writeRadiance(w.path / "pe.exr", 640, 512, 1e9f,
                      {{"nvstim.unit", "pe/s/m2/sr"}, {"nvstim.camera", "pulnix-ag5745ef3"}});
    const fs::path out = w.path / "o.pgm";
    expectRefused(
        nvstim("sensor --in " + pe.string() + " --camera boson-640 --out " + out.string()),
        "radiance in pe/s/m2/sr (rendered for camera 'pulnix-ag5745ef3')", out);
    // The visible render's band radiance (W/m2/sr, its own band).
    const fs::path band = writeRadiance(w.path / "pe.band.exr", 640, 512, 1e-3f,
                                        {{"nvstim.unit", "W/m2/sr"},
                                         {"nvstim.camera", "pulnix-ag5745ef3"},
                                         {"nvstim.band", "camera relative response beta"}});
    expectRefused(
        nvstim("sensor --in " + band.string() + " --camera boson-640 --out " + out.string()),
        "band 'camera relative response beta'", out);
}

TEST(ThermalCli, ThermalRenderIntoIntensifiedPresetIsRefused) {
    WorkDir w;
    const fs::path out = w.path / "o.pgm";
    expectRefused(nvstim("sensor --in " + nightRender().string() +
                         " --camera pulnix-ag5745ef3 --out " + out.string()),
                  "a thermal render (camera 'boson-640', band 'LWIR 7.5-13.5 um')", out);
}

TEST(ThermalCli, AnotherSizeOrBandIsRefused) {
    WorkDir w;
    const fs::path out = w.path / "o.pgm";
    expectRefused(nvstim("sensor --in " + nightRender().string() + " --camera boson-320 --out " +
                         out.string()),
                  "image is 640x512 (rendered for camera 'boson-640'), thermal camera "
                  "'boson-320' expects 320x256",
                  out);
    const fs::path other = writeRadiance(
        w.path / "b.exr", 640, 512, 30.0f,
        {{"nvstim.unit", "W/m2/sr"}, {"nvstim.camera", "mwir"}, {"nvstim.band", "LWIR 8-14 um"}});
    expectRefused(
        nvstim("sensor --in " + other.string() + " --camera boson-640 --out " + out.string()),
        "band 'LWIR 8-14 um'", out);
    expectRefused(nvstim("sensor --in " + nightRender().string() +
                         " --camera boson-640 --unit pe/s/m2/sr --out " + out.string()),
                  "--unit pe/s/m2/sr: a thermal camera takes W/m2/sr", out);
}

TEST(ThermalCli, BadPixelOrStartupRadianceIsRefused) {
    WorkDir w;
    const fs::path out = w.path / "o.pgm";
    ImageF img(320, 256);
    img.fill(50.0f);
    img(7, 3) = -1.0f;
    io::writeExr(w.path / "neg.exr", img.cview(), {{{"nvstim.unit", "W/m2/sr"}}, {}, {}});
    expectRefused(nvstim("sensor --in " + (w.path / "neg.exr").string() +
                         " --camera boson-320 --out " + out.string()),
                  "pixel (7, 3) is -1.000000; radiance must be finite and >= 0", out);
    const fs::path bad =
        writeRadiance(w.path / "bad.exr", 320, 256, 50.0f,
                      {{"nvstim.unit", "W/m2/sr"}, {"nvstim.startup_W_m2_sr", "warm"}});
    expectRefused(
        nvstim("sensor --in " + bad.string() + " --camera boson-320 --out " + out.string()),
        "nvstim.startup_W_m2_sr 'warm' is not a radiance", out);
}

// A pattern's frames are all read and checked before anything is written: frame 1 of another
// camera stops the run with nothing written for frame 0 either.
TEST(ThermalCli, PatternWithAForeignFrameWritesNothing) {
    WorkDir w;
    writeRadiance(w.path / "000000.exr", 320, 256, 50.0f, {{"nvstim.unit", "W/m2/sr"}});
    writeRadiance(w.path / "000001.exr", 320, 256, 1e9f, {{"nvstim.unit", "pe/s/m2/sr"}});
    const auto r = nvstim("sensor --in " + (w.path / "{frame:06d}.exr").string() +
                          " --camera boson-320 --out " + (w.path / "o{frame:06d}.pgm").string());
    expectRefused(r, "000001.exr: radiance in pe/s/m2/sr", w.path / "o000001.pgm");
    EXPECT_FALSE(fs::exists(w.path / "o000000.pgm"));
}

// A preset given as a path is thermal when its folder is named thermal_cameras (as a scenario's
// [camera] preset): the same file elsewhere is read as an intensified preset and fails there.
TEST(ThermalCli, PresetPathInAThermalCamerasFolder) {
    WorkDir w;
    fs::create_directories(w.path / "thermal_cameras");
    fs::copy(kSource / "config/thermal_cameras/boson-320.toml", w.path / "thermal_cameras/my.toml");
    fs::copy(kSource / "config/thermal_cameras/boson-320.toml", w.path / "my.toml");
    const fs::path in = writeRadiance(w.path / "bb.exr", 320, 256, 55.5f, {});
    const auto ok = nvstim("sensor --in " + in.string() + " --camera " +
                           (w.path / "thermal_cameras/my.toml").string() + " --out " +
                           (w.path / "o.pgm").string());
    EXPECT_EQ(ok.status, 0) << ok.err;
    EXPECT_NE(ok.out.find("\"band\":\"LWIR 7.5-13.5 um\""), std::string::npos) << ok.out;
    const auto other =
        nvstim("sensor --in " + in.string() + " --camera " + (w.path / "my.toml").string() +
               " --out " + (w.path / "p.pgm").string());
    EXPECT_EQ(other.status, 2) << other.err;
    EXPECT_FALSE(fs::exists(w.path / "p.pgm"));
}

TEST(ThermalCli, ImageWithoutHeaderIsTakenAsBandRadiance) {
    WorkDir w;
    // A uniform 300 K blackbody in the band (Planck: 55.5 W m⁻² sr⁻¹ over 7.5-13.5 µm) written
    // by another program: no nvstim header.
    const fs::path in = writeRadiance(w.path / "bb.exr", 320, 256, 55.5f, {});
    const fs::path out = w.path / "o.pgm";
    const auto s =
        nvstim("sensor --in " + in.string() + " --camera boson-320 --out " + out.string());
    ASSERT_EQ(s.status, 0) << s.err;
    EXPECT_TRUE(fs::exists(out));
    EXPECT_NE(s.out.find("\"frozen\":false"), std::string::npos) << s.out;
}

}  // namespace
}  // namespace nvs
