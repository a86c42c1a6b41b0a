#include "sim/core/image.h"

#include <gtest/gtest.h>

#include <cstdint>

namespace nvs {
namespace {

TEST(Image, RowsAre64ByteAlignedWithStride) {
    ImageF f(101, 7);
    EXPECT_EQ(f.width(), 101);
    EXPECT_EQ(f.height(), 7);
    EXPECT_EQ(f.stride_px(), 112);  // 101 floats rounded up to 16-float (64-byte) rows
    for (int y = 0; y < f.height(); ++y) {
        EXPECT_EQ(reinterpret_cast<std::uintptr_t>(f.row(y)) % 64, 0u);
    }
    ImageU8 b(65, 2);
    EXPECT_EQ(b.stride_px(), 128);
    ImageU16 w(32, 2);
    EXPECT_EQ(w.stride_px(), 32);
    EXPECT_EQ(f(100, 6), 0.0f);  // zero-initialised
}

TEST(Image, RegionSharesPixels) {
    ImageU16 img(16, 16);
    ImageView<std::uint16_t> r = img.view().region(4, 5, 3, 2);
    r.fill(7);
    EXPECT_EQ(img(4, 5), 7);
    EXPECT_EQ(img(6, 6), 7);
    EXPECT_EQ(img(7, 6), 0);
    EXPECT_EQ(img(4, 7), 0);
    EXPECT_EQ(r.stride_px(), img.stride_px());
}

TEST(Image, CopyIsDeepAndMoveTransfers) {
    ImageF a(3, 3);
    a(1, 1) = 2.5f;
    ImageF b = a;
    b(1, 1) = 1.0f;
    EXPECT_EQ(a(1, 1), 2.5f);
    ImageF c = std::move(a);
    EXPECT_EQ(c(1, 1), 2.5f);
}

TEST(Image, QuantizeRoundsAndClamps) {
    ImageF src(4, 1);
    src(0, 0) = -3.0f;
    src(1, 0) = 1.49f;
    src(2, 0) = 1.51f;
    src(3, 0) = 1e9f;
    ImageU8 dst8(4, 1);
    quantize(src.cview(), dst8.view(), 1.0f, 0.0f);
    EXPECT_EQ(dst8(0, 0), 0);
    EXPECT_EQ(dst8(1, 0), 1);
    EXPECT_EQ(dst8(2, 0), 2);
    EXPECT_EQ(dst8(3, 0), 255);
    ImageU16 dst16(4, 1);
    quantize(src.cview(), dst16.view(), 100.0f, 10.0f);
    EXPECT_EQ(dst16(1, 0), 159);
    EXPECT_EQ(dst16(3, 0), 65535);
}

}  // namespace
}  // namespace nvs
