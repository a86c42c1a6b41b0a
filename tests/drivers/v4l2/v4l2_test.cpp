// V4L2 output: the real wrapper (V4l2Output / V4l2Sink) run against FakeV4l2Loopback, which
// answers the ioctls with v4l2loopback 0.12's semantics (page-rounded sizeimage, a format kept
// across S_FMT, non-blocking DQBUF), and against a real output node when one exists.
#include "drivers/v4l2/v4l2.h"

#include <gtest/gtest.h>

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "drivers/v4l2/fake/fake_v4l2.h"
#include "rt/loop/frame_loop.h"
#include "rt/synth/synth.h"

namespace nvs::drivers {
namespace {

// A frame of counts to hand to the sink.
struct Counts {
    ImageU16 img;
    rt::FrameMeta meta;
    rt::OutputFrame frame(std::int64_t tick, std::int64_t mono_ns, int bits) const {
        rt::OutputFrame f;
        f.meta = &meta;
        f.counts = img.cview();
        f.bits = bits;
        f.tick = tick;
        f.emitMonotonic_ns = mono_ns;
        return f;
    }
};

Counts ramp(int w, int h, int bits) {
    Counts c{ImageU16(w, h), {}};
    const int maxc = (1 << bits) - 1;
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            c.img.view().row(y)[x] = static_cast<std::uint16_t>((x + 7 * y) % (maxc + 1));
    return c;
}

TEST(V4l2Capability, PredicatesReadDeviceCapsWhenPresent) {
    v4l2_capability raw{};
    raw.capabilities = V4L2_CAP_VIDEO_OUTPUT | V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_DEVICE_CAPS;
    raw.device_caps = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING;  // this node: capture only
    const V4l2Capability cap(raw);
    EXPECT_FALSE(cap.isVideoOutput());
    EXPECT_TRUE(cap.hasStreaming());
    EXPECT_FALSE(cap.hasReadWrite());
    raw.capabilities = V4L2_CAP_VIDEO_OUTPUT | V4L2_CAP_READWRITE;  // no DEVICE_CAPS: use these
    EXPECT_TRUE(V4l2Capability(raw).isVideoOutput());
    EXPECT_TRUE(V4l2Capability(raw).hasReadWrite());
}

TEST(V4l2Output, AbsentNodeAndCaptureOnlyNodeAreRefused) {
    FakeV4l2Loopback dev("/dev/video9");
    V4l2Output out(dev);
    EXPECT_EQ(out.open("/dev/video3"), -ENOENT);
    EXPECT_NE(out.message().find("/dev/video3"), std::string::npos);
    dev.outputCapable = false;
    EXPECT_EQ(out.open("/dev/video9"), -EINVAL);
    EXPECT_NE(out.message().find("not a video output"), std::string::npos) << out.message();
    EXPECT_EQ(out.state(), V4l2State::Closed);
    dev.outputCapable = true;
    EXPECT_EQ(out.open("/dev/video9"), 0);
    EXPECT_EQ(out.state(), V4l2State::Open);
    EXPECT_EQ(out.capability().driver(), "v4l2 loopback");
}

// 100×75 GREY is 7500 bytes; 0.12 reports sizeimage = 8192 (two 4-KiB pages). Every write must
// still be exactly 7500 bytes: one write() is one frame to the loopback.
TEST(V4l2Output, WritesExactlyWidthHeightBppWhenSizeimageIsPageRounded) {
    FakeV4l2Loopback dev;
    V4l2Output out(dev);
    ASSERT_EQ(out.open("/dev/video9"), 0);
    ASSERT_EQ(out.configure(100, 75, V4l2Format::Grey, V4l2Io::Write), 0) << out.message();
    EXPECT_EQ(out.activeFormat().sizeimage, 8192u);
    EXPECT_EQ(out.frameBytes(), 7500u);
    for (int k = 0; k < 3; ++k) {
        std::uint8_t* p = out.acquire();
        ASSERT_NE(p, nullptr);
        std::memset(p, k + 1, out.frameBytes());
        ASSERT_EQ(out.submit(static_cast<std::uint32_t>(k), 0), 0);
    }
    ASSERT_EQ(dev.writeSizes.size(), 3u);
    for (const std::size_t n : dev.writeSizes)
        EXPECT_EQ(n, 7500u);
    EXPECT_EQ(dev.frames[2].data[7499], 3);
    EXPECT_EQ(out.counters().frames, 3);
    EXPECT_EQ(out.counters().bytes, 3 * 7500);
    EXPECT_EQ(out.state(), V4l2State::Streaming);
}

TEST(V4l2Output, KeptOldFormatIsDetectedByReadBackAndReported) {
    FakeV4l2Loopback dev;
    dev.holdFormat(640, 480, V4L2_PIX_FMT_YUYV);  // a previous writer's format, held by a reader
    V4l2Output out(dev);
    ASSERT_EQ(out.open("/dev/video9"), 0);
    EXPECT_EQ(out.configure(320, 240, V4l2Format::Grey, V4l2Io::Write), -EBUSY);
    EXPECT_EQ(out.counters().formatMismatches, 1);
    EXPECT_NE(out.message().find("kept 640x480 YUYV"), std::string::npos) << out.message();
    EXPECT_EQ(out.state(), V4l2State::Open);  // nothing is written in a wrong format
    EXPECT_EQ(out.acquire(), nullptr);
    // The sink turns it into a setup error naming the device.
    try {
        V4l2Sink sink(std::make_unique<FakeV4l2Loopback>(std::move(dev)), "/dev/video9", 320, 240,
                      8, V4l2Format::Grey, V4l2Io::Write);
        FAIL() << "expected a setup error";
    } catch (const std::exception& e) {
        EXPECT_NE(std::string(e.what()).find("v4l2:/dev/video9"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("kept"), std::string::npos) << e.what();
    }
}

TEST(V4l2Output, MmapStreamingCarriesSequenceAndTimestampAndReleasesEverything) {
    auto owned = std::make_unique<FakeV4l2Loopback>();
    FakeV4l2Loopback& dev = *owned;
    const int w = 100, h = 76;
    {
        V4l2Sink sink(std::move(owned), "/dev/video9", w, h, 10, V4l2Format::Y16, V4l2Io::Mmap);
        EXPECT_EQ(sink.output().bufferCount(), 4);
        EXPECT_EQ(dev.mappedCount(), 4);
        EXPECT_FALSE(dev.isStreaming());  // STREAMON waits for the first filled buffer
        const Counts c = ramp(w, h, 10);
        for (int k = 0; k < 10; ++k) {
            ASSERT_EQ(sink.write(c.frame(k, 1'000'000'000LL + k * 16'683'333LL, 10)), 0);
        }
        EXPECT_TRUE(dev.isStreaming());
        ASSERT_EQ(dev.frames.size(), 10u);
        for (int k = 0; k < 10; ++k) {
            const auto& f = dev.frames[static_cast<std::size_t>(k)];
            EXPECT_TRUE(f.streamed);
            EXPECT_EQ(f.data.size(), static_cast<std::size_t>(w * h * 2));
            EXPECT_EQ(f.sequence, static_cast<std::uint32_t>(k));
            // timeval has microseconds: the timestamp survives to the microsecond.
            EXPECT_EQ(f.timestamp_ns, (1'000'000'000LL + k * 16'683'333LL) / 1000 * 1000);
        }
        // Y16 little-endian, 10-bit counts scaled to the full 16 bits: 1023 → 65535.
        const auto& d = dev.frames[9].data;
        for (int x = 0; x < w; ++x) {
            const unsigned c10 = c.img.cview().row(5)[x];
            const unsigned v = d[static_cast<std::size_t>(2 * (5 * w + x))] |
                               (d[static_cast<std::size_t>(2 * (5 * w + x) + 1)] << 8);
            EXPECT_EQ(v, static_cast<unsigned>(std::lround(c10 * 65535.0 / 1023.0)));
        }
        sink.close();
        EXPECT_FALSE(dev.isStreaming());
        EXPECT_EQ(dev.mappedCount(), 0);
    }
}

// The consumer stops taking buffers: frames are skipped and counted as busy, not errors; when it
// catches up, frames flow again.
TEST(V4l2Output, ConsumerThatFallsBehindIsCountedNotFatal) {
    auto owned = std::make_unique<FakeV4l2Loopback>();
    FakeV4l2Loopback& dev = *owned;
    V4l2Sink sink(std::move(owned), "/dev/video9", 32, 16, 8, V4l2Format::Grey, V4l2Io::Mmap);
    const Counts c = ramp(32, 16, 8);
    dev.stallConsumer = true;
    for (int k = 0; k < 6; ++k)
        EXPECT_EQ(sink.write(c.frame(k, k, 8)), 0);
    EXPECT_EQ(sink.output().counters().frames, 4);  // four buffers queued
    EXPECT_EQ(sink.output().counters().busy, 2);    // two frames found no free buffer
    EXPECT_EQ(sink.output().counters().errors, 0);
    dev.releaseConsumer();
    EXPECT_EQ(sink.write(c.frame(6, 6, 8)), 0);
    EXPECT_EQ(sink.output().counters().frames, 5);
    EXPECT_EQ(dev.frames.size(), 5u);
    EXPECT_EQ(dev.frames.back().sequence, 6u);
}

// A node that vanishes (ENODEV: module unloaded, gadget unplugged) is counted, its frames are
// lost (counted), and it is reopened and reconfigured with backoff once it is back; the run goes
// on. Before: it stayed failed for the rest of the run, an error every frame.
TEST(V4l2Sink, DeviceThatVanishesIsCountedAndReopenedWithBackoff) {
    for (const V4l2Io io : {V4l2Io::Write, V4l2Io::Mmap}) {
        auto owned = std::make_unique<FakeV4l2Loopback>();
        FakeV4l2Loopback& dev = *owned;
        V4l2Sink sink(std::move(owned), "/dev/video9", 32, 16, 8, V4l2Format::Grey, io);
        const Counts c = ramp(32, 16, 8);
        // Frames at 100 Hz on the emission clock (emit_s).
        const auto at = [&](int k) {
            rt::OutputFrame f = c.frame(k, 0, 8);
            f.emit_s = 0.01 * k;
            return f;
        };
        for (int k = 0; k < 5; ++k)
            ASSERT_EQ(sink.write(at(k)), 0);
        dev.unplug(ENODEV);
        int failures = 0;
        // Found gone at frame 5 (its write fails) and counted at frame 6; retries (0.1 s, then
        // doubling) at frames 16 and 36 fail while it is away.
        for (int k = 5; k < 40; ++k)
            failures += sink.write(at(k)) < 0 ? 1 : 0;
        EXPECT_EQ(failures, 35);
        EXPECT_EQ(sink.output().state(), V4l2State::Failed);
        EXPECT_NE(sink.status().find("DEVICE LOST"), std::string::npos) << sink.status();
        EXPECT_NE(sink.status().find("reopen attempts 2"), std::string::npos) << sink.status();
        dev.replug();
        int k = 40;
        while (k < 200 && sink.write(at(k)) != 0)
            ++k;
        // The next retry is 0.4 s after the one at frame 36: frame 76 (within a frame: the
        // instants are sums of binary fractions).
        EXPECT_GE(k, 75) << sink.status();
        EXPECT_LE(k, 77) << sink.status();
        for (int j = k + 1; j < k + 5; ++j)
            EXPECT_EQ(sink.write(at(j)), 0);
        EXPECT_EQ(sink.deviceLosses(), 1);
        EXPECT_EQ(sink.reopened(), 1);
        EXPECT_EQ(sink.output().counters().frames, 5 + 5);
        EXPECT_EQ(dev.openCount(), 2);
        EXPECT_NE(sink.status().find("frames lost " + std::to_string(k - 6)), std::string::npos)
            << sink.status();
        EXPECT_EQ(sink.status().find("DEVICE LOST"), std::string::npos) << sink.status();
        EXPECT_EQ(sink.close(), 0);
    }
}

TEST(V4l2Sink, CountsMapToEachFormatsRange) {
    // 10-bit counts → GREY: v = round(c·255/1023); YUYV: Y = 16 + round(c·219/1023), U = V = 128.
    std::vector<std::uint16_t> lutGrey(1024), lutY(1024);
    for (int c = 0; c < 1024; ++c) {
        lutGrey[static_cast<std::size_t>(c)] =
            static_cast<std::uint16_t>(std::lround(c * 255.0 / 1023.0));
        lutY[static_cast<std::size_t>(c)] =
            static_cast<std::uint16_t>(16 + std::lround(c * 219.0 / 1023.0));
    }
    const std::uint16_t counts[4] = {0, 512, 1023, 100};
    std::uint8_t grey[4], yuyv[8];
    V4l2Sink::convertRow(counts, 4, V4l2Format::Grey, lutGrey.data(), grey);
    EXPECT_EQ(grey[0], 0);
    EXPECT_EQ(grey[1], 128);  // 127.62 rounds up
    EXPECT_EQ(grey[2], 255);
    V4l2Sink::convertRow(counts, 4, V4l2Format::Yuyv, lutY.data(), yuyv);
    const std::uint8_t want[8] = {16, 128, 126, 128, 235, 128, 37, 128};
    for (int i = 0; i < 8; ++i)
        EXPECT_EQ(yuyv[i], want[i]) << i;

    // Through the sink: an 8-bit GREY frame of 8-bit counts is the counts themselves.
    auto owned = std::make_unique<FakeV4l2Loopback>();
    FakeV4l2Loopback& dev = *owned;
    V4l2Sink sink(std::move(owned), "/dev/video9", 40, 10, 8, V4l2Format::Grey, V4l2Io::Write);
    const Counts c = ramp(40, 10, 8);
    ASSERT_EQ(sink.write(c.frame(0, 0, 8)), 0);
    ASSERT_EQ(dev.frames.size(), 1u);
    for (int y = 0; y < 10; ++y)
        for (int x = 0; x < 40; ++x)
            ASSERT_EQ(dev.frames[0].data[static_cast<std::size_t>(y * 40 + x)],
                      c.img.cview().row(y)[x]);
}

// The frame loop driving the V4L2 sink: every sim-clock frame reaches the device, in order,
// with the test pattern's known counts.
TEST(V4l2Sink, FrameLoopStreamsEveryFrameToTheDevice) {
    auto owned = std::make_unique<FakeV4l2Loopback>();
    FakeV4l2Loopback& dev = *owned;
    V4l2Sink sink(std::move(owned), "/dev/video9", 64, 48, 8, V4l2Format::Grey, V4l2Io::Mmap);
    rt::LoopConfig cfg;
    cfg.rate = rt::FrameRate{60, 1};
    cfg.clock = rt::ClockKind::Sim;
    cfg.frames = 30;
    cfg.width = 64;
    cfg.height = 48;
    rt::HeldPlatform platform(rt::PlatformState{});
    rt::TestPatternRender render(1e-4, 40.0);
    rt::LinearCamera camera(1e-4, 8);
    rt::FrameLoop loop(cfg, platform, render, camera, {&sink});
    std::vector<std::string> msgs;
    loop.start(msgs);
    loop.join();
    sink.close();
    ASSERT_EQ(dev.frames.size(), 30u);
    for (std::size_t k = 0; k < 30; ++k)
        EXPECT_EQ(dev.frames[k].sequence, k);
    // Bar i of the pattern (top rows) is round(255·i/7).
    for (int i = 0; i < 8; ++i)
        EXPECT_EQ(dev.frames[29].data[static_cast<std::size_t>(i * 8 + 4)],
                  std::lround(255.0 * i / 7.0))
            << "bar " << i;
}

// A real output node (v4l2loopback) when there is one; the HIL set-up provides it.
TEST(V4l2Device, RealLoopbackNodeTakesFrames) {
    std::string node;
    for (int i = 0; i < 64 && node.empty(); ++i) {
        const std::string p = "/dev/video" + std::to_string(i);
        if (!std::filesystem::exists(p)) continue;
        KernelV4l2Ops ops;
        V4l2Output probe(ops);
        if (probe.open(p) == 0) node = p;
    }
    if (node.empty()) GTEST_SKIP() << "no V4L2 output device (load v4l2loopback: docs/hil.md)";
    auto ops = std::make_unique<KernelV4l2Ops>();
    V4l2Sink sink(std::move(ops), node, 64, 48, 8, V4l2Format::Grey, V4l2Io::Write);
    const Counts c = ramp(64, 48, 8);
    for (int k = 0; k < 5; ++k)
        EXPECT_EQ(sink.write(c.frame(k, k, 8)), 0);
    EXPECT_EQ(sink.output().counters().frames + sink.output().counters().busy, 5);
    EXPECT_EQ(sink.output().activeFormat().width, 64u);
}

}  // namespace
}  // namespace nvs::drivers
