// sim/fit's building blocks against analytic cases: the dataset folder round trip and its
// errors (docs/contracts.md "Measured dataset"), PNG/PGM frames, the convolution kernels (unit
// sum, centred, ring radius), the least-squares gain/offset, the held-out paired score.
#include "sim/fit/dataset.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <random>

#include "sim/core/error.h"
#include "sim/fit/conv.h"
#include "sim/fit/engine.h"
#include "sim/fit/generate.h"
#include "sim/io/png.h"
#include "sim/io/pnm.h"
#include "tests/sim/fit/fit_test_data.h"

namespace nvs::fit {
namespace {

namespace fs = std::filesystem;
using test::kConfig;
using test::small;
using test::tempDir;

void replaceLine(const fs::path& file, const std::string& start, const std::string& line) {
    std::ifstream in(file);
    std::string text, l;
    while (std::getline(in, l))
        text += (l.rfind(start, 0) == 0 ? line : l) + "\n";
    std::ofstream(file) << text;
}

TEST(Dataset, WriteThenLoadGivesTheSameFramesAndStimuli) {
    const Generated g = small();
    const fs::path dir = tempDir("roundtrip");
    writeDataset(g.data, dir);
    const Dataset d = loadDataset(dir, kConfig);
    ASSERT_EQ(d.frameCount(), g.data.frameCount());
    EXPECT_EQ(d.width, 48);
    EXPECT_EQ(d.height, 32);
    EXPECT_EQ(d.stimuli.size(), 3u);  // one per hold block, read once
    EXPECT_EQ(d.stimulusOfFrame, g.data.stimulusOfFrame);
    EXPECT_EQ(d.settings.at("gain_V"), "4.0");
    for (std::size_t k = 0; k < d.frameCount(); ++k)
        EXPECT_EQ(d.frames[k], g.data.frames[k]) << "frame " << k;
    for (std::size_t s = 0; s < d.stimuli.size(); ++s)
        EXPECT_FLOAT_EQ(d.stimuli[s](10, 10), g.data.stimuli[s](10, 10));
}

TEST(Dataset, BadInputIsOneSetupErrorNamingTheProblem) {
    const Generated g = small();
    const std::vector<test::SpoilCase> cases = {
        {"no preset",
         [](const fs::path& d) { replaceLine(d / "dataset.toml", "preset", "preset = \"nope\""); },
         "no preset"},
        {"unit",
         [](const fs::path& d) { replaceLine(d / "dataset.toml", "unit", "unit = \"lux\""); },
         "cannot be converted"},
        {"missing frame", [](const fs::path& d) { fs::remove(d / "frames" / "000005.pgm"); },
         "frame 5 is missing"},
        {"gap without count",
         [](const fs::path& d) {
             replaceLine(d / "dataset.toml", "count", "");
             fs::remove(d / "frames" / "000005.pgm");
         },
         "frame 5 is missing (frame 6 exists)"},
        {"out of order",
         [](const fs::path& d) {
             replaceLine(d / "dataset.toml", "frames",
                         "frames = [\"frames/000000.pgm\", \"frames/000001.pgm\", "
                         "\"frames/000003.pgm\", \"frames/000002.pgm\"]");
             replaceLine(d / "dataset.toml", "count", "");
         },
         "not consecutive and increasing"},
        {"stimulus size",
         [](const fs::path& d) {
             ImageF small(24, 16);
             io::writePfm(d / "radiance" / "000001.pfm", small.cview());
         },
         "stimulus is 24x16 but the frames are 48x32"},
    };
    test::expectEachSetupError(g.data, cases, "bad");
}

TEST(Dataset, ReadsEightAndSixteenBitPngAndPgm) {
    const fs::path dir = tempDir("png");
    ImageU16 img(5, 3);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 5; ++x)
            img(x, y) = static_cast<std::uint16_t>(1000 * y + 37 * x);
    io::writePng(dir / "a16.png", img.cview(), 65535);
    io::writePgm(dir / "a16.pgm", img.cview(), 65535);
    img(4, 2) = 255;
    img(0, 0) = 0;
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 5; ++x)
            img(x, y) = static_cast<std::uint16_t>(img(x, y) % 256);
    io::writePng(dir / "a8.png", img.cview(), 255);
    int w = 0, h = 0, maxv = 0;
    const Plane p16 = readFrame(dir / "a16.png", w, h, maxv);
    EXPECT_EQ(maxv, 65535);
    EXPECT_EQ(p16[2 * 5 + 4], 2000.0f + 4 * 37);
    const Plane g16 = readFrame(dir / "a16.pgm", w, h, maxv);
    EXPECT_EQ(g16, p16);
    const Plane p8 = readFrame(dir / "a8.png", w, h, maxv);
    EXPECT_EQ(maxv, 255);
    EXPECT_EQ(w, 5);
    EXPECT_EQ(h, 3);
    EXPECT_EQ(p8[2 * 5 + 4], 255.0f);
    EXPECT_EQ(p8[1 * 5 + 1], static_cast<float>((1000 + 37) % 256));
}

TEST(Convolver, RingKernelHasUnitSumAndItsRadius) {
    // A point through the halo ring: all its light lands on a circle of the ring's radius
    // (18 µm pixels: a 90 µm ring is 5 px), centred on the point.
    Convolver conv(64, 48, 18.0, 18.0);
    Plane d(64 * 48, 0.0f), o;
    d[24 * 64 + 32] = 1.0f;
    conv.convolveOne(d, ringKernel(90.0, 18.0), o);
    double sum = 0.0, cx = 0.0, cy = 0.0, r = 0.0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x) {
            const double v = static_cast<double>(o[static_cast<std::size_t>(y) * 64 + x]);
            sum += static_cast<double>(v);
            cx += x * v;
            cy += y * v;
            r += v * std::hypot(x - 32, y - 24);
        }
    EXPECT_NEAR(sum, 1.0, 1e-4);
    EXPECT_NEAR(cx / sum, 32.0, 1e-3);
    EXPECT_NEAR(cy / sum, 24.0, 1e-3);
    EXPECT_NEAR(r / sum, 5.0, 0.1);
}

TEST(Convolver, AUniformSceneStaysUniformUpToTheEdges) {
    // A normalised kernel convolved with a constant gives the constant (the scene past the
    // edge is the mirror of the scene inside). Zero padding darkened the border: with a
    // 300 µm halo ring (17 px) on a 96 × 64 frame, the corners kept about a quarter.
    Convolver conv(96, 64, 18.0, 18.0);
    const Plane d(96 * 64, 7.5f);
    for (const auto& k : {ringKernel(300.0, 18.0), expKernel(400.0)}) {
        Plane o;
        conv.convolveOne(d, k, o);
        float lo = 1e9f, hi = -1e9f;
        for (float v : o) {
            lo = std::min(lo, v);
            hi = std::max(hi, v);
        }
        EXPECT_NEAR(lo, 7.5f, 1e-3f);
        EXPECT_NEAR(hi, 7.5f, 1e-3f);
    }
}

TEST(Convolver, LightSpreadPastAnEdgeComesBackAsTheMirrorScenes) {
    // A point in the corner and its three mirror images outside: the veil inside the frame
    // holds the point's light but for the kernel's tail past the far edges (an exponential of
    // 5 px scale on a 32 px frame: (1 + r/s)·e^(−r/s) ≈ 1 % beyond 32 px).
    Convolver conv(32, 32, 10.0, 10.0);
    Plane d(32 * 32, 0.0f), o;
    d[0] = 1.0f;
    conv.convolveOne(d, expKernel(50.0), o);
    double sum = 0.0;
    for (float v : o)
        sum += static_cast<double>(v);
    EXPECT_GT(sum, 0.95);
    EXPECT_LT(sum, 1.001);
    EXPECT_GT(o[0], o[1]);  // still peaked on the point
}

TEST(Search, GoldenSectionFindsTheMinimumOfAParabolaInLogSpace) {
    const double x = searchLog(
        [](double v) { return (std::log(v) - std::log(3.7)) * (std::log(v) - std::log(3.7)); }, 0.1,
        100.0, 8);
    EXPECT_NEAR(x, 3.7, 0.01);
}

TEST(Score, PairedTestIsZeroForEqualErrorsAndLargeForAClearGain) {
    std::vector<double> a(50, 1.0), b(50, 1.0);
    EXPECT_EQ(pairedScore(a, b, 1, 1, 1).z, 0.0);
    std::mt19937_64 rng(3);
    std::normal_distribution<double> n(0.0, 0.1);
    for (auto& v : b)
        v = 0.5 + n(rng);
    const Score s = pairedScore(a, b, 1, 0.7, 2);
    EXPECT_GT(s.z, 20.0);
    EXPECT_NEAR(s.score, s.z * s.z - 2 * std::log(50.0), 1e-9);
}

}  // namespace
}  // namespace nvs::fit
