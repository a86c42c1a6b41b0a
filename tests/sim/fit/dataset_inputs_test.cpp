// The dataset loader against hostile and careless input (issue 27, docs/reliability-inputs.md):
// a FIFO or /dev/zero as the preset or a frame, a PNG header that promises more than its file,
// a frame count or number past its range, an ROI whose end overflows, mixed bit depths, too few
// frames to calibrate and hold out, frames with no signal. Each is one SetupError naming the
// file or key, before anything large is allocated; an interlaced 16-bit PNG reads as its plain
// twin and a quote in a [camera.settings] string stays a quote.
#include <gtest/gtest.h>
#include <png.h>
#include <sys/stat.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include "sim/core/error.h"
#include "sim/fit/dataset.h"
#include "sim/fit/generate.h"
#include "sim/io/frame_pattern.h"
#include "sim/io/png.h"
#include "sim/io/pnm.h"
#include "tests/sim/fit/fit_test_data.h"

namespace nvs::fit {
namespace {

namespace fs = std::filesystem;
using test::kConfig;
using test::tempDir;

// One generated dataset for every case (each writes its own copy and spoils it).
const Generated& small() {
    static const Generated g = test::small();
    return g;
}

std::string readText(const fs::path& p) {
    std::ifstream in(p);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Replaces the first occurrence of `from` in the file by `to`.
void edit(const fs::path& file, const std::string& from, const std::string& to) {
    std::string t = readText(file);
    const std::size_t at = t.find(from);
    ASSERT_NE(at, std::string::npos) << from << " in " << t;
    t.replace(at, from.size(), to);
    std::ofstream(file) << t;
}

void writeBytes(const fs::path& p, const std::string& bytes) {
    std::ofstream(p, std::ios::binary) << bytes;
}

std::uint32_t crc32(const std::string& s) {
    std::uint32_t c = 0xffffffffu;
    for (const char ch : s) {
        c ^= static_cast<unsigned char>(ch);
        for (int k = 0; k < 8; ++k)
            c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return ~c;
}

std::string be32(std::uint32_t v) {
    return {static_cast<char>(v >> 24), static_cast<char>(v >> 16), static_cast<char>(v >> 8),
            static_cast<char>(v)};
}

std::string chunk(const std::string& type, const std::string& data) {
    return be32(static_cast<std::uint32_t>(data.size())) + type + data + be32(crc32(type + data));
}

// A valid PNG signature and IHDR claiming side x side 16-bit grey, a tiny IDAT, IEND.
std::string forgedPng(std::uint32_t side) {
    const std::string ihdr = be32(side) + be32(side) + std::string{16, 0, 0, 0, 0};
    return std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) +
           chunk("IDAT", std::string("\x78\x9c\x03\x00\x00\x00\x00\x01", 8)) + chunk("IEND", "");
}

TEST(DatasetInputs, HostileInputIsOneSetupErrorNamingIt) {
    const std::vector<test::SpoilCase> cases = {
        {"preset a FIFO",
         [](const fs::path& d) {
             ::mkfifo((d / "p.toml").c_str(), 0600);
             edit(d / "dataset.toml", "preset = \"pulnix-ag5745ef3\"", "preset = \"p.toml\"");
         },
         "a FIFO"},
        {"preset /dev/zero",
         [](const fs::path& d) {
             edit(d / "dataset.toml", "preset = \"pulnix-ag5745ef3\"", "preset = \"/dev/zero\"");
         },
         "character device"},
        {"frame a FIFO",
         [](const fs::path& d) {
             fs::remove(d / "frames" / "000003.pgm");
             ::mkfifo((d / "frames" / "000003.pgm").c_str(), 0600);
         },
         "000003.pgm: frame: a FIFO"},
        {"frame /dev/zero",
         [](const fs::path& d) {
             fs::remove(d / "frames" / "000003.pgm");
             fs::create_symlink("/dev/zero", d / "frames" / "000003.pgm");
         },
         "000003.pgm: frame: a character device"},
        {"frame a symlink loop",
         [](const fs::path& d) {
             fs::remove(d / "frames" / "000003.pgm");
             fs::create_symlink(d / "frames" / "000003.pgm", d / "frames" / "000003.pgm");
         },
         "000003.pgm"},
        {"PNG header of 16384 squared in 69 bytes",
         [](const fs::path& d) {
             edit(d / "dataset.toml", "{frame:06d}.pgm", "{frame:06d}.png");
             for (int k = 0; k < 12; ++k)
                 writeBytes(d / "frames" / io::expandFramePattern("{frame:06d}.png", k),
                            forgedPng(16384));
         },
         "000000.png: PNG header claims 16384x16384"},
        {"PNG header of 30000 squared",
         [](const fs::path& d) {
             edit(d / "dataset.toml", "{frame:06d}.pgm", "{frame:06d}.png");
             for (int k = 0; k < 12; ++k)
                 writeBytes(d / "frames" / io::expandFramePattern("{frame:06d}.png", k),
                            forgedPng(30000));
         },
         "PNG header claims 30000x30000"},
        {"16-bit PNG with a corrupt IDAT",
         [](const fs::path& d) {
             edit(d / "dataset.toml", "{frame:06d}.pgm", "{frame:06d}.png");
             ImageU16 img(48, 32);
             for (int y = 0; y < 32; ++y)
                 for (int x = 0; x < 48; ++x)
                     img(x, y) = static_cast<std::uint16_t>(1000 * x + y);
             for (int k = 0; k < 12; ++k)
                 io::writePng(d / "frames" / io::expandFramePattern("{frame:06d}.png", k),
                              img.cview(), 65535);
             std::string png = readText(d / "frames" / "000000.png");
             const std::size_t idat = png.find("IDAT");
             png[idat + 40] = static_cast<char>(png[idat + 40] ^ 0x5a);
             writeBytes(d / "frames" / "000000.png", png);
         },
         "000000.png: PNG read failed: "},
        {"count 10^12",
         [](const fs::path& d) { edit(d / "dataset.toml", "count = 12", "count = 1000000000000"); },
         "'output.count': must be in [8, 100000]"},
        {"count -5",
         [](const fs::path& d) { edit(d / "dataset.toml", "count = 12", "count = -5"); },
         "'output.count': must be in [8, 100000]"},
        {"24-digit frame number",
         [](const fs::path& d) {
             edit(d / "dataset.toml", "frames = \"frames/{frame:06d}.pgm\"",
                  "frames = [\"frames/123456789012345678901234.pgm\"]");
             edit(d / "dataset.toml", "count = 12", "");
         },
         "more than 15 digits"},
        {"ROI end overflows",
         [](const fs::path& d) {
             std::ofstream(d / "dataset.toml", std::ios::app)
                 << "\n[[roi]]\nname = \"wrap\"\nx = 2147483647\ny = 0\nw = 10\nh = 4\n";
         },
         "'wrap' lies outside the frame"},
        {"PGM maximum value 1000",
         [](const fs::path& d) {
             ImageU16 img(48, 32);
             io::writePgm(d / "frames" / "000000.pgm", img.cview(), 1000);
         },
         "maximum value 1000 is not 2^n - 1"},
        {"mixed bit depths",
         [](const fs::path& d) {
             ImageU16 img(48, 32);
             img(3, 3) = 100;
             io::writePgm(d / "frames" / "000004.pgm", img.cview(), 65535);
         },
         "mixed bit depths"},
        {"too few frames to hold any out",
         [](const fs::path& d) { edit(d / "dataset.toml", "count = 12", "count = 5"); },
         "must be in [8, 100000]"},
        {"six frames listed",
         [](const fs::path& d) {
             edit(d / "dataset.toml", "frames = \"frames/{frame:06d}.pgm\"",
                  "frames = [\"frames/000000.pgm\", \"frames/000001.pgm\", \"frames/000002.pgm\","
                  " \"frames/000003.pgm\", \"frames/000004.pgm\", \"frames/000005.pgm\"]");
             edit(d / "dataset.toml", "count = 12", "");
         },
         "diagnose needs at least 8"},
        {"all frames dark",
         [](const fs::path& d) {
             const ImageU16 img(48, 32);
             for (int k = 0; k < 12; ++k)
                 io::writePgm(d / "frames" / io::expandFramePattern("{frame:06d}.pgm", k),
                              img.cview(), 255);
         },
         "carry no signal: every sample is 0"},
        {"all frames clipped",
         [](const fs::path& d) {
             ImageU16 img(48, 32);
             for (int y = 0; y < 32; ++y)
                 for (int x = 0; x < 48; ++x)
                     img(x, y) = (x + y) % 2 == 0 ? 0 : 255;
             for (int k = 0; k < 12; ++k)
                 io::writePgm(d / "frames" / io::expandFramePattern("{frame:06d}.pgm", k),
                              img.cview(), 255);
         },
         "carry no signal: every sample is 0 or full scale (255)"},
    };
    ASSERT_EQ(small().data.frames.size(), 12u);
    test::expectEachSetupError(small().data, cases, "inputs-bad");
}

// Writes `img` as a 16-bit grey PNG, Adam7-interlaced when `interlaced`.
void writePng16(const fs::path& p, const ImageU16& img, bool interlaced) {
    FILE* f = std::fopen(p.c_str(), "wb");
    ASSERT_NE(f, nullptr);
    png_structp png = png_create_write_struct(PNG_LIBPNG_VER_STRING, nullptr, nullptr, nullptr);
    png_infop info = png_create_info_struct(png);
    png_init_io(png, f);
    png_set_IHDR(png, info, static_cast<png_uint_32>(img.width()),
                 static_cast<png_uint_32>(img.height()), 16, PNG_COLOR_TYPE_GRAY,
                 interlaced ? PNG_INTERLACE_ADAM7 : PNG_INTERLACE_NONE,
                 PNG_COMPRESSION_TYPE_DEFAULT, PNG_FILTER_TYPE_DEFAULT);
    png_write_info(png, info);
    std::vector<std::vector<png_byte>> rows(static_cast<std::size_t>(img.height()));
    std::vector<png_bytep> ptrs;
    for (int y = 0; y < img.height(); ++y) {
        for (int x = 0; x < img.width(); ++x) {
            rows[y].push_back(static_cast<png_byte>(img(x, y) >> 8));
            rows[y].push_back(static_cast<png_byte>(img(x, y) & 0xff));
        }
        ptrs.push_back(rows[y].data());
    }
    png_write_image(png, ptrs.data());
    png_write_end(png, nullptr);
    png_destroy_write_struct(&png, &info);
    std::fclose(f);
}

TEST(DatasetInputs, InterlacedSixteenBitPngReadsAsItsPlainTwin) {
    const fs::path dir = tempDir("inputs-adam7");
    ImageU16 img(13, 9);
    for (int y = 0; y < 9; ++y)
        for (int x = 0; x < 13; ++x)
            img(x, y) = static_cast<std::uint16_t>(4001 * y + 97 * x + 3);
    writePng16(dir / "plain.png", img, false);
    writePng16(dir / "adam7.png", img, true);
    int w = 0, h = 0, maxv = 0;
    const Plane plain = readFrame(dir / "plain.png", w, h, maxv);
    const Plane adam7 = readFrame(dir / "adam7.png", w, h, maxv);
    EXPECT_EQ(maxv, 65535);
    EXPECT_EQ(plain[8 * 13 + 12], static_cast<float>(4001 * 8 + 97 * 12 + 3));
    EXPECT_EQ(adam7, plain);
    fs::remove_all(dir);
}

TEST(DatasetInputs, ASettingsStringKeepsItsQuote) {
    const fs::path dir = tempDir("inputs-quote");
    writeDataset(small().data, dir);
    edit(dir / "dataset.toml", "[camera.settings]\n",
         "[camera.settings]\n\"name\" = \"pulnix \\\"night\\\" \\\\ test\"\n");
    const Dataset d = loadDataset(dir, kConfig);
    EXPECT_EQ(d.camera.name, "pulnix \"night\" \\ test");
    fs::remove_all(dir);
}

}  // namespace
}  // namespace nvs::fit
