// Image inputs bounded (docs/reliability-inputs.md): a header's size is checked against the
// bytes the file holds and against the limits (the camera's size) before any pixel is
// allocated — a 36-byte PFM claiming 20000×20000 allocated 1.5 GB before — numbers in a header
// are bounded, and frame-name patterns with an overlong width no longer throw.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <functional>
#include <iterator>
#include <string>

#include "sim/core/error.h"
#include "sim/io/exr.h"
#include "sim/io/frame_pattern.h"
#include "sim/io/image_file.h"
#include "sim/io/pnm.h"
#include "tests/sim/core/test_errors.h"

namespace nvs::io {
namespace {

TEST(ImageInput, PfmHeaderClaimingMoreThanTheFileHoldsIsRefusedBeforeAllocating) {
    const std::string path = ::testing::TempDir() + "nvs_huge_claim.pfm";
    std::string bytes = "Pf\n20000 20000\n-1.0\n";
    bytes.resize(36, '\0');
    std::ofstream(path, std::ios::binary) << bytes;
    // The default limits (16384²) refuse it from the header alone, ...
    EXPECT_NE(nvs::test::setupErrorOf([&] { readRadiance(path); }).find("larger than the limit"),
              std::string::npos);
    // ... and with a larger limit, the file's 16 bytes of samples refuse it.
    ImageLimits wide;
    wide.maxWidth = wide.maxHeight = 20000;
    const std::string e = nvs::test::setupErrorOf([&] { readRadiance(path, wide); });
    EXPECT_NE(e.find("header promises 1600000000 bytes of samples, the file holds 16"),
              std::string::npos)
        << e;
    // The camera's size is a limit too.
    ImageLimits cam;
    cam.maxWidth = 768;
    cam.maxHeight = 494;
    EXPECT_NE(nvs::test::setupErrorOf([&] { readRadiance(path, cam); }).find("limit of 768x494"),
              std::string::npos);
}

TEST(ImageInput, SmallPfmAndPgmRead) {
    std::string pfm = "Pf\n2 1\n-1.0\n";
    const float px[2] = {1.5f, -2.0f};
    pfm.append(reinterpret_cast<const char*>(px), sizeof px);
    const ImageF f = parsePfm(pfm, "a.pfm", ImageLimits{});
    EXPECT_EQ(f(0, 0), 1.5f);
    EXPECT_EQ(f(1, 0), -2.0f);
    const ImageU16 g =
        parsePgm(std::string("P5\n# c\n2 1\n4095\n\x01\x02\x0f\xff", 20), "a.pgm", ImageLimits{});
    EXPECT_EQ(g(0, 0), 0x0102);
    EXPECT_EQ(g(1, 0), 0x0fff);
}

TEST(ImageInput, HeaderNumbersAreBounded) {
    // std::stoi threw std::out_of_range on the first; the others are not sizes at all.
    for (const char* h : {"P5\n99999999999 1\n255\n", "P5\n-3 1\n255\n", "P5\n2 1\n70000\n",
                          "P5\n1e3 1\n255\n", "P5\n"}) {
        EXPECT_NE(
            nvs::test::setupErrorOf([&] { parsePgm(h, "b.pgm", ImageLimits{}); }).find("b.pgm"),
            std::string::npos)
            << h;
    }
    EXPECT_NE(nvs::test::setupErrorOf([] {
                  parsePfm("Pf\n1 1\nnan\n\0\0\0\0", "c.pfm", ImageLimits{});
              }).find("bad scale"),
              std::string::npos);
    EXPECT_NE(nvs::test::setupErrorOf([] {
                  parseExr("not an exr", "d.exr", ImageLimits{});
              }).find("d.exr"),
              std::string::npos);
}

std::string seed(const char* file) {
    std::ifstream in(std::string(NVS_SOURCE_DIR) + "/tests/fuzz/image/corpus/" + file,
                     std::ios::binary);
    return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

TEST(ImageInput, ExrHeaderIsWalkedBeforeOpenExrAllocates) {
    // Written by OpenEXR (uncompressed, ZIP, RLE with a data window off the origin): read.
    const ExrImage a = parseExr(seed("y_none_4x3.exr"), "a.exr", ImageLimits{});
    EXPECT_EQ(a.image.width(), 4);
    EXPECT_EQ(a.image.height(), 3);
    EXPECT_EQ(a.image(3, 2), 0.25f * 11);
    EXPECT_EQ(a.attribute(kExrUnit), "pe/s/m2/sr");
    EXPECT_EQ(parseExr(seed("r_half_rle_5x2_offset.exr"), "b.exr", ImageLimits{}).image.width(), 5);
    // Found by the image fuzz target: a 360-byte header whose string attribute claims 1.9 GB,
    // which OpenEXR 3.1 allocated before reading it.
    const std::string e = nvs::test::setupErrorOf(
        [] { parseExr(seed("crash-exr-attribute-size-1.9GB"), "c.exr", ImageLimits{}); });
    EXPECT_NE(e.find("larger than the file"), std::string::npos) << e;
    // The data window against the limits, before OpenEXR sizes its line table from it.
    EXPECT_NE(nvs::test::setupErrorOf([] {
                  ImageLimits l;
                  l.maxWidth = l.maxHeight = 3;
                  parseExr(seed("y_none_4x3.exr"), "d.exr", l);
              }).find("limit of 3x3"),
              std::string::npos);
}

TEST(FramePattern, OverlongWidthIsLeftAsIs) {
    // std::stoi threw std::out_of_range for this width.
    EXPECT_EQ(expandFramePattern("f{frame:099999999999d}.pgm", 7), "f{frame:099999999999d}.pgm");
    EXPECT_EQ(expandFramePattern("f{frame:021d}.pgm", 7), "f{frame:021d}.pgm");
    EXPECT_EQ(expandFramePattern("f{frame:06d}.pgm", 7), "f000007.pgm");
    EXPECT_EQ(expandFramePattern("f{frame:6d}.pgm", 7), "f000007.pgm");
    EXPECT_EQ(expandFramePattern("{frame}/{frame:03d}", 12), "12/{frame:03d}");
    EXPECT_EQ(expandFramePattern("{frame:x}{frame:2d}", 5), "{frame:x}05");
}

}  // namespace
}  // namespace nvs::io
