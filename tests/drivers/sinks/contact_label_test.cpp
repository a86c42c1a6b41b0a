// The contact sheet labels each tile with its frame number and time (a 3 × 5 pixel font drawn
// in a strip under the tile), and leaves the tile's pixels as they were; PNG and EXR outputs
// report the bytes they wrote (they said "bytes 0").
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "drivers/sinks/sinks.h"
#include "sim/core/image.h"
#include "sim/io/png.h"

namespace nvs::drivers {
namespace {

namespace fs = std::filesystem;

std::string slurp(const fs::path& p) {
    std::ifstream f(p, std::ios::binary);
    std::stringstream ss;
    ss << f.rdbuf();
    return ss.str();
}

struct TempFolder {
    fs::path path = fs::temp_directory_path() /
                    ("nvs_contact_label_" + std::to_string(::getpid()) + "_" +
                     ::testing::UnitTest::GetInstance()->current_test_info()->name());
    TempFolder() {
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~TempFolder() { fs::remove_all(path); }
};

// The glyphs as drawn (rows top to bottom, '#' black), written out by hand from the font's
// design: a ring for 0, a flagged stem on a base for 1, a centred dot for '.'.
const char* const kZero[5] = {"###", "#.#", "#.#", "#.#", "###"};
const char* const kOne[5] = {".#.", "##.", ".#.", ".#.", "###"};
const char* const kDot[5] = {"...", "...", "...", "...", ".#."};

// The glyph at (x, y) of the sheet, scale 1, against a hand-drawn pattern.
void expectGlyph(const ImageU16& sheet, int x, int y, const char* const rows[5],
                 const std::string& what) {
    for (int r = 0; r < 5; ++r)
        for (int c = 0; c < 3; ++c)
            EXPECT_EQ(sheet(x + c, y + r), rows[r][c] == '#' ? 0 : 255)
                << what << " at (" << c << ", " << r << ")";
}

TEST(ContactSheetLabel, TilesCarryTheirFrameAndTimeAndKeepTheirPixels) {
    const TempFolder dir;
    const fs::path png = dir.path / "sheet.png";
    // Two tiles of 32 × 24 (64 × 48 frames shrunk by 2), side by side: frames 0 and 1 of 2.
    ContactSheetSink sink(png.string(), 64, 48, 8, 2, 1, 2, 2, 0);
    ASSERT_EQ(sink.labelScale(), 1);  // 32 px tiles: one sheet pixel per font pixel
    const int values[2] = {100, 200};
    const double times_s[2] = {0.0, 1.5};
    for (int k = 0; k < 2; ++k) {
        ImageU16 counts(64, 48);
        counts.fill(static_cast<std::uint16_t>(values[k]));
        msg::FrameMeta meta;
        meta.frame = k;
        meta.t_sample_s = times_s[k];
        msg::OutputFrame f;
        f.meta = &meta;
        f.counts = counts.cview();
        f.bits = 8;
        f.tick = k;
        ASSERT_EQ(sink.write(f), 0);
    }
    ASSERT_EQ(sink.close(), 0);
    const std::string bytes = slurp(png);
    const ImageU16 sheet = io::parsePng(bytes, png.string(), {});
    // The layout by hand: 4 px gaps; each tile 24 rows and a label strip of 7 (5 font rows, one
    // above, one below).
    ASSERT_EQ(sheet.width(), 4 + 32 + 4 + 32 + 4);
    ASSERT_EQ(sheet.height(), 4 + 24 + 7 + 4);
    ASSERT_EQ(sheet.width(), sink.sheetWidth());
    ASSERT_EQ(sheet.height(), sink.sheetHeight());
    // The tiles: every pixel the frame's value, none drawn over.
    for (int k = 0; k < 2; ++k) {
        const int x0 = 4 + k * 36, y0 = 4;
        ASSERT_EQ(sink.tileX(k), x0);
        ASSERT_EQ(sink.tileY(k), y0);
        int changed = 0;
        for (int y = y0; y < y0 + 24; ++y)
            for (int x = x0; x < x0 + 32; ++x)
                changed += sheet(x, y) != values[k] ? 1 : 0;
        EXPECT_EQ(changed, 0) << "tile " << k;
    }
    // The labels start one row under the tile: "0 0.000s" and "1 1.500s".
    const int ly = 4 + 24 + 1;
    ASSERT_EQ(sink.labelY(0), ly);
    expectGlyph(sheet, 4, ly, kZero, "tile 0, frame digit");
    expectGlyph(sheet, 4 + 8, ly, kZero, "tile 0, time's first digit");  // "0 " then "0"
    expectGlyph(sheet, 4 + 12, ly, kDot, "tile 0, decimal point");
    expectGlyph(sheet, 40, ly, kOne, "tile 1, frame digit");
    expectGlyph(sheet, 40 + 8, ly, kOne, "tile 1, time's first digit");
    // Black only inside the label rows, the rest of the strip and the gaps white.
    int black = 0;
    for (int y = 0; y < sheet.height(); ++y) {
        for (int x = 0; x < sheet.width(); ++x) {
            const bool tile = y >= 4 && y < 28 && ((x >= 4 && x < 36) || (x >= 40 && x < 72));
            if (tile) continue;
            const bool labelRow = y >= ly && y < ly + 5;
            if (!labelRow) {
                EXPECT_EQ(sheet(x, y), 255) << "(" << x << ", " << y << ")";
            } else if (sheet(x, y) == 0) {
                ++black;
            } else {
                EXPECT_EQ(sheet(x, y), 255) << "(" << x << ", " << y << ")";
            }
        }
    }
    EXPECT_GT(black, 0);
    // The sink reports the PNG file's bytes.
    EXPECT_NE(sink.status().find("bytes " + std::to_string(bytes.size())), std::string::npos)
        << sink.status();
}

// A label wider than its tile is cut at the tile's right edge: the gap beside it stays white.
TEST(ContactSheetLabel, ALabelWiderThanItsTileIsCutAtItsEdge) {
    const TempFolder dir;
    const fs::path png = dir.path / "narrow.png";
    ContactSheetSink sink(png.string(), 16, 16, 8, 2, 1, 1, 0, 1);  // 16 px tiles, every frame
    ImageU16 counts(16, 16);
    counts.fill(50);
    msg::FrameMeta meta;
    meta.frame = 1234567;
    meta.t_sample_s = 98765.4321;
    msg::OutputFrame f;
    f.meta = &meta;
    f.counts = counts.cview();
    for (int k = 0; k < 2; ++k) {
        f.tick = k;
        ASSERT_EQ(sink.write(f), 0);
    }
    ASSERT_EQ(sink.close(), 0);
    const ImageU16 sheet = io::parsePng(slurp(png), png.string(), {});
    for (int y = 0; y < sheet.height(); ++y)
        for (int x = 20; x < 24; ++x)  // the gap between the two tiles
            EXPECT_EQ(sheet(x, y), 255) << "(" << x << ", " << y << ")";
}

// PNG and EXR frames report the bytes of the files they wrote, as y4m, PGM and the metadata do.
TEST(Sinks, PngAndExrReportTheBytesWritten) {
    const TempFolder dir;
    ImageU16 counts(5, 4);
    counts.fill(77);
    ImageF lpe(5, 4), band(5, 4);
    lpe.fill(1e6f);
    band.fill(1e-7f);
    msg::FrameMeta meta;
    msg::OutputFrame f;
    f.meta = &meta;
    f.counts = counts.cview();
    f.radiance = msg::RadianceFrame{lpe.cview(), band.cview()};
    PngSequenceSink png((dir.path / "png").string(), 5, 4, 8);
    ExrSequenceSink exr((dir.path / "exr").string(), 5, 4);
    for (int k = 0; k < 2; ++k) {
        f.tick = k;
        ASSERT_EQ(png.write(f), 0);
        ASSERT_EQ(exr.write(f), 0);
    }
    png.close();
    exr.close();
    for (const auto& [sink, folder] :
         {std::pair<const msg::FrameSink*, fs::path>{&png, dir.path / "png"},
          std::pair<const msg::FrameSink*, fs::path>{&exr, dir.path / "exr"}}) {
        std::uintmax_t onDisk = 0;
        int files = 0;
        for (const auto& e : fs::directory_iterator(folder)) {
            onDisk += fs::file_size(e.path());
            ++files;
        }
        EXPECT_EQ(files, folder.filename() == "exr" ? 4 : 2);
        EXPECT_GT(onDisk, 0u);
        EXPECT_NE(sink->status().find("frames 2, errors 0, bytes " + std::to_string(onDisk)),
                  std::string::npos)
            << sink->status();
    }
}

}  // namespace
}  // namespace nvs::drivers
