// The chain run by bands on other threads, in other orders: the same bits as on one thread
// (sim/sensor/chain.h: every draw is keyed by pixel, every sum is added up in row order).

#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <limits>
#include <thread>
#include <vector>

#include "sim/core/row_executor.h"
#include "sim/sensor/chain.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace nvs::sensor {
namespace {

// Three threads taking one index at a time from a shared counter, as a pool does.
class ConcurrentExecutor final : public RowExecutor {
  public:
    void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept override {
        std::atomic<int> next{0};
        const auto work = [&] {
            for (int i = next.fetch_add(1); i < rows; i = next.fetch_add(1))
                fn(ctx, i, i + 1);
        };
        std::thread a(work), b(work);
        work();
        a.join();
        b.join();
        calls += 1;
    }
    int calls = 0;
};

// One index at a time, last first.
class ReverseExecutor final : public RowExecutor {
  public:
    void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept override {
        for (int i = rows - 1; i >= 0; --i)
            fn(ctx, i, i + 1);
    }
};

// Dark sky, a lit gradient, a lamp far past full well (PTRS means, blooming, MCP saturation),
// and a few bad pixels.
ImageF scene(int w, int h) {
    ImageF img(w, h);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x) {
            float v =
                y < h / 3 ? 2e11f : 1e12f + 3e13f * static_cast<float>(x) / static_cast<float>(w);
            const float dx = static_cast<float>(x - 3 * w / 4), dy = static_cast<float>(y - h / 2);
            if (dx * dx + dy * dy < 400.0f) v = 5e16f;
            img(x, y) = v;
        }
    img(5, 7) = std::numeric_limits<float>::quiet_NaN();
    img(w - 3, h - 2) = -1.0f;
    return img;
}

void expectSameFields(const CameraParams& cam) {
    const ImageF in = scene(cam.width, cam.height);
    IiccdChain one(cam, 7, test::configDir(), test::gammaTables());
    IiccdChain conc(cam, 7, test::configDir(), test::gammaTables());
    IiccdChain rev(cam, 7, test::configDir(), test::gammaTables());
    ConcurrentExecutor cx;
    ReverseExecutor rx;
    conc.setExecutor(&cx);
    rev.setExecutor(&rx);
    std::int64_t saturated = 0;
    for (int f = 0; f < 4; ++f) {
        const FieldInfo a = one.process(in.cview());
        for (IiccdChain* c : {&conc, &rev}) {
            const FieldInfo& b = c->process(in.cview());
            EXPECT_EQ(a.level_dc, b.level_dc) << cam.name << " field " << f;
            EXPECT_EQ(a.mean_pe, b.mean_pe);
            EXPECT_EQ(a.mcp_gain, b.mcp_gain);
            EXPECT_EQ(a.screen_current_A, b.screen_current_A);
            EXPECT_EQ(a.saturated_px, b.saturated_px);
            EXPECT_EQ(a.bad_input_px, b.bad_input_px);
            int differ = 0;
            for (int y = 0; y < cam.height; ++y)
                for (int x = 0; x < cam.width; ++x) {
                    differ += one.video()(x, y) != c->video()(x, y) ? 1 : 0;
                    differ += one.electrons()(x, y) != c->electrons()(x, y) ? 1 : 0;
                }
            EXPECT_EQ(differ, 0) << cam.name << " field " << f;
        }
        EXPECT_EQ(a.bad_input_px, 2);
        saturated += a.saturated_px;
    }
    EXPECT_GT(saturated, 0);  // the lamp reached full well: blooming ran
    EXPECT_GT(cx.calls, 0);   // the bands did go through the executor
}

// The CCD's load by bands of rows (each band's column maxima, the sums and the blooming down
// sweep after) gives loadRow's values, with fixed pattern, dark charge, smear and vertical
// blooming all on, whatever order the rows come in.
TEST(ChainThreads, CcdLoadByBandsEqualsLoadRow) {
    CameraParams cam = test::calibrationTube({{"width", "64"}, {"height", "48"}});
    cam.full_well_e = 500.0;
    cam.prnu_rel = 0.05;
    cam.smear_rel = 0.02;
    cam.dark_e_s = 3000.0;
    cam.scan = ScanMode::Frame;
    ImageF src(64, 48);
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x)
            src(x, y) = static_cast<float>((x * 37 + y * 11) % 97) - 5.0f;  // some below zero
    src(10, 5) = 4000.0f;
    src(40, 30) = 9000.0f;
    src(41, 30) = 700.0f;
    CcdStage a(cam, 3), b(cam, 3);
    FieldContext ctx;
    ctx.period_s = 1.0 / 59.94;
    ImageF ea(64, 48), eb(64, 48);
    a.begin(ctx);
    for (int y = 0; y < 48; ++y)
        a.loadRow(src.row(y), ea.row(y), y);
    const std::int64_t satA = a.bloom(ea.view());
    b.begin(ctx);
    b.beginLoad();
    for (int y = 47; y >= 0; --y)
        b.loadRowMax(src.row(y), eb.row(y), y, y % kChainSlots);
    b.finishLoad(eb.view());
    const std::int64_t satB = b.bloom(eb.view());
    EXPECT_GT(satA, 0);
    EXPECT_EQ(satA, satB);
    int differ = 0;
    for (int y = 0; y < 48; ++y) {
        a.finishRow(ea.row(y), y);
        b.finishRow(eb.row(y), y, y % kChainSlots);
        for (int x = 0; x < 64; ++x)
            differ += ea(x, y) != eb(x, y) ? 1 : 0;
    }
    EXPECT_EQ(differ, 0);
}

TEST(ChainThreads, ShippedPresetSameBitsOnAnyThreadsAndOrder) {
    expectSameFields(test::preset("pulnix-ag5745ef3"));  // halo: the optics run first
}

TEST(ChainThreads, RowByRowOpticsAndBspSameBits) {
    expectSameFields(test::calibrationTube());  // no halo: optics row by row
    expectSameFields(test::preset("pulnix-ag5745ef3", {{"agc", "bsp"}}));
}

TEST(ChainThreads, NoBlurSameBits) {
    expectSameFields(test::preset("pulnix-ag5745ef3", {{"mtf.enabled", "false"}}));
}

}  // namespace
}  // namespace nvs::sensor
