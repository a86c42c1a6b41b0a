// The image files' exact bytes (docs/contracts.md): PFM and PGM against hand-written files,
// every format written and read back, and the PNG colour chunks of each writer.
#include <gtest/gtest.h>
#include <png.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

#include "sim/io/exr.h"
#include "sim/io/image_file.h"
#include "sim/io/png.h"
#include "sim/io/pnm.h"

namespace nvs::io {
namespace {

namespace fs = std::filesystem;

fs::path tempPath(const std::string& name) {
    return fs::temp_directory_path() / ("nvs_io_test-" + std::to_string(::getpid()) + "-" + name);
}

std::string bytesOf(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// 1.0f, 2.0f, -0.5f, 3.0f as little- and big-endian IEEE 754 bytes.
constexpr char kOneLe[] = {'\x00', '\x00', '\x80', '\x3f'};
constexpr char kTwoLe[] = {'\x00', '\x00', '\x00', '\x40'};
constexpr char kMinusHalfLe[] = {'\x00', '\x00', '\x00', '\xbf'};
constexpr char kThreeLe[] = {'\x00', '\x00', '\x40', '\x40'};

std::string le(const char (&b)[4]) {
    return std::string(b, 4);
}
std::string be(const char (&b)[4]) {
    return std::string{b[3], b[2], b[1], b[0]};
}

// The image [[1 2] [-0.5 3]] (row 0 on top).
ImageF twoByTwo() {
    ImageF img(2, 2);
    img(0, 0) = 1.0f;
    img(1, 0) = 2.0f;
    img(0, 1) = -0.5f;
    img(1, 1) = 3.0f;
    return img;
}

TEST(Pfm, WrittenBytesAreTheHandWrittenFile) {
    const fs::path p = tempPath("a.pfm");
    writePfm(p, twoByTwo().cview());
    // Header, then the bottom row first, little-endian (scale -1).
    const std::string expected =
        "Pf\n2 2\n-1.0\n" + le(kMinusHalfLe) + le(kThreeLe) + le(kOneLe) + le(kTwoLe);
    EXPECT_EQ(bytesOf(p), expected);
    fs::remove(p);
}

TEST(Pfm, HandWrittenFilesOfBothByteOrdersRead) {
    const std::string little =
        "Pf\n2 2\n-1.0\n" + le(kMinusHalfLe) + le(kThreeLe) + le(kOneLe) + le(kTwoLe);
    const std::string big =
        "Pf 2 2 # comment\n1.0\n" + be(kMinusHalfLe) + be(kThreeLe) + be(kOneLe) + be(kTwoLe);
    for (const std::string& bytes : {little, big}) {
        const ImageF img = parsePfm(bytes, "t.pfm", {});
        ASSERT_EQ(img.width(), 2);
        ASSERT_EQ(img.height(), 2);
        EXPECT_EQ(img(0, 0), 1.0f);
        EXPECT_EQ(img(1, 0), 2.0f);
        EXPECT_EQ(img(0, 1), -0.5f);
        EXPECT_EQ(img(1, 1), 3.0f);
    }
    // PF (colour): the first channel of each pixel.
    const std::string colour = "PF\n1 1\n-1\n" + le(kTwoLe) + le(kOneLe) + le(kOneLe);
    EXPECT_EQ(parsePfm(colour, "c.pfm", {})(0, 0), 2.0f);
}

TEST(Pfm, RoundTrip) {
    ImageF img(7, 5);
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 7; ++x)
            img(x, y) = static_cast<float>(x) * 0.37f - static_cast<float>(y) * 1e-7f;
    const fs::path p = tempPath("r.pfm");
    writePfm(p, img.cview());
    const RadianceFile back = readRadiance(p);
    ASSERT_EQ(back.image.width(), 7);
    ASSERT_EQ(back.image.height(), 5);
    for (int y = 0; y < 5; ++y)
        for (int x = 0; x < 7; ++x)
            EXPECT_EQ(back.image(x, y), img(x, y));
    fs::remove(p);
}

TEST(Pgm, EncodedBytesAreTheHandWrittenFile) {
    ImageU16 img(2, 1);
    img(0, 0) = 0x0102;
    img(1, 0) = 0x03ff;
    std::string out(pgmFileBytes(2, 1, 1023), '\0');
    ASSERT_EQ(encodePgm(img.cview(), 1023, reinterpret_cast<unsigned char*>(out.data())),
              out.size());
    EXPECT_EQ(out, std::string("P5\n2 1\n1023\n\x01\x02\x03\xff", 16));
    // 8 bit: the low byte.
    std::string out8(pgmFileBytes(2, 1, 255), '\0');
    encodePgm(img.cview(), 255, reinterpret_cast<unsigned char*>(out8.data()));
    EXPECT_EQ(out8, std::string("P5\n2 1\n255\n\x02\xff", 13));
    int maxv = 0;
    const ImageU16 back = parsePgm(out, "t.pgm", {}, &maxv);
    EXPECT_EQ(maxv, 1023);
    EXPECT_EQ(back(0, 0), 0x0102);
    EXPECT_EQ(back(1, 0), 0x03ff);
    const fs::path p = tempPath("w.pgm");
    writePgm(p, img.cview(), 1023);
    EXPECT_EQ(bytesOf(p), out);
    fs::remove(p);
}

// Whether the PNG file holds a chunk of this type.
bool hasChunk(const std::string& png, const char* type) {
    return png.find(type) != std::string::npos;
}

TEST(Png, RoundTripAndColourChunks) {
    ImageU16 img(5, 3);
    for (int y = 0; y < 3; ++y)
        for (int x = 0; x < 5; ++x)
            img(x, y) = static_cast<std::uint16_t>(x * 9000 + y * 7);
    for (const bool wide : {false, true}) {
        const fs::path p = tempPath(wide ? "16.png" : "8.png");
        writePng(p, img.cview(), wide ? 65535 : 255);
        const std::string none = bytesOf(p);
        EXPECT_FALSE(hasChunk(none, "sRGB") || hasChunk(none, "gAMA") || hasChunk(none, "cHRM"));
        const CountsFile back = readCounts(p);
        EXPECT_EQ(back.maxValue, wide ? 65535 : 255);
        for (int y = 0; y < 3; ++y)
            for (int x = 0; x < 5; ++x)
                EXPECT_EQ(back.image(x, y), wide ? img(x, y) : (img(x, y) & 0xff));
        // The sinks' tag: what libpng's simplified API writes, byte for byte.
        {
            FileOut out(p);
            out.close(writePng(out.fd(), img.cview(), wide ? 16 : 8, PngColour::Srgb));
        }
        const std::string srgb = bytesOf(p);
        EXPECT_EQ(hasChunk(srgb, "sRGB"), !wide);
        EXPECT_EQ(hasChunk(srgb, "gAMA") && hasChunk(srgb, "cHRM"), wide);
        std::vector<unsigned char> b8(15);
        for (std::size_t i = 0; i < 15; ++i)
            b8[i] = static_cast<unsigned char>(img.cview().row(static_cast<int>(i / 5))[i % 5]);
        png_image pi{};
        pi.version = PNG_IMAGE_VERSION;
        pi.width = 5;
        pi.height = 3;
        pi.format = wide ? PNG_FORMAT_LINEAR_Y : PNG_FORMAT_GRAY;
        const fs::path q = tempPath("simplified.png");
        ASSERT_NE(png_image_write_to_file(
                      &pi, q.c_str(), 0,
                      wide ? static_cast<const void*>(img.cview().row(0))
                           : static_cast<const void*>(b8.data()),
                      wide ? static_cast<png_int_32>(img.cview().stride_px()) : 0, nullptr),
                  0);
        png_image_free(&pi);
        EXPECT_EQ(srgb, bytesOf(q)) << (wide ? "16 bit" : "8 bit");
        fs::remove(q);
        fs::remove(p);
    }
}

TEST(Exr, CarriesAttributesAndPixels) {
    ImageF img(8, 4);
    img(3, 2) = 42.0f;
    const fs::path p = tempPath("a.exr");
    ExrAttributes a;
    a.strings = {{kExrUnit, "pe/s/m2/sr"}, {"nvstim.utc", "x"}};
    a.ints = {{"nvs_frame", 7}};
    a.doubles = {{"nvs_t_sample_s", 0.25}};
    writeExr(p, img.cview(), a);
    const ExrImage back = readExr(p);
    EXPECT_EQ(back.image(3, 2), 42.0f);
    EXPECT_EQ(back.attribute(kExrUnit), "pe/s/m2/sr");
    EXPECT_EQ(back.attribute("nvstim.utc"), "x");
    EXPECT_EQ(back.attribute("absent"), "");
    const RadianceFile r = readRadiance(p);
    EXPECT_EQ(r.unit, "pe/s/m2/sr");
    EXPECT_EQ(r.spectrum, "");
    // A view with a stride wider than its width is written as its pixels only.
    ImageF wide(16, 4);
    wide(3, 2) = 42.0f;
    const fs::path q = tempPath("b.exr");
    writeExr(q, wide.cview().region(0, 0, 8, 4), a);
    EXPECT_EQ(bytesOf(q), bytesOf(p));
    fs::remove(p);
    fs::remove(q);
}

}  // namespace
}  // namespace nvs::io
