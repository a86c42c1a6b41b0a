// The stages composed one by one, each over the whole image by its apply(), give IiccdChain's
// bits (sim/sensor/chain.h): the chain runs the same row operations interleaved, by bands of
// rows, and the two orders must agree exactly.

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstring>

#include "sim/core/units.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace nvs::sensor {
namespace {

constexpr std::uint64_t kSeed = 20240611;

// A scene with structure at every scale: a smooth pattern about a level that gives ~60 DC, a
// lamp that saturates the CCD (blooming) and a dark hole.
ImageF scene(const CameraParams& cam) {
    const double pePerField = 60.0 / cam.dcPerPhotoelectron(cam.gain_V);
    const double lpe = pePerField / (cam.peRatePerLpe_on_axis() * cam.integrationPeriod_s());
    ImageF img(cam.width, cam.height);
    for (int y = 0; y < cam.height; ++y)
        for (int x = 0; x < cam.width; ++x) {
            double v = lpe * (1.0 + 0.6 * std::sin(0.05 * x) * std::cos(0.07 * y));
            if (std::abs(x - 200) < 4 && std::abs(y - 150) < 4) v *= 400.0;
            if (std::abs(x - 500) < 20 && std::abs(y - 300) < 20) v = 0.0;
            img(x, y) = static_cast<float>(v);
        }
    return img;
}

// The stages of the chain, composed by their whole-image apply(), with the preset's own
// controls (no gain loop: these presets run at their manual gain).
class ComposedStages {
  public:
    explicit ComposedStages(const CameraParams& cam)
        : cam_(cam),
          optics_(cam_),
          gate_(cam_),
          cathode_(cam_, kSeed),
          halo_(cam_),
          bsp_(cam_),
          mcp_(cam_, kSeed, test::gammaTables()),
          phosphor_(cam_),
          blur_(cam_, ChainOptions{}, test::configDir()),
          ccd_(cam_, kSeed),
          video_(cam_),
          rate_(cam_.width, cam_.height),
          e_(cam_.width, cam_.height),
          counts_(cam_.width, cam_.height),
          out_(cam_.width, cam_.height) {
        counts_.fill(static_cast<float>(std::clamp(cam_.video_offset_dc, 0.0, 65535.0)));
    }

    void field(ImageView<const float> lpe, std::uint64_t k) {
        FieldContext ctx;
        ctx.field = k;
        ctx.period_s = cam_.integrationPeriod_s();
        ctx.gain_V = cam_.gain_V;
        ctx.gate_s = gate_.gate_s(ctx.period_s, 1.0);
        optics_.apply(lpe, rate_.view(), ctx);
        halo_.apply(rate_.view());
        cathode_.apply(rate_.cview(), e_.view(), ctx);
        const double current_A =
            ctx.cathodeRate_pe_s * ctx.gate_s / ctx.period_s * kElectronCharge_C;
        const double bspFactor = bsp_.enabled() ? bsp_.factor(current_A) : 1.0;
        ctx.mcpGain = cam_.mcpGain(ctx.gain_V) * bspFactor;
        if (mcp_.enabled()) mcp_.apply(e_.view(), ctx);
        phosphor_.apply(e_.view(), ctx);
        blur_.apply(e_.view());
        saturated_ = ccd_.apply(e_.view(), ctx);
        level_dc_ = video_.apply(e_.cview(), k, counts_.view(), out_.view());
    }

    const ImageF& electrons() const { return e_; }
    const ImageF& counts() const { return counts_; }
    const ImageU16& video() const { return out_; }
    double level_dc() const { return level_dc_; }
    std::int64_t saturated() const { return saturated_; }

  private:
    CameraParams cam_;
    OpticsStage optics_;
    GateStage gate_;
    PhotocathodeStage cathode_;
    HaloStage halo_;
    BspStage bsp_;
    McpStage mcp_;
    PhosphorStage phosphor_;
    BlurStage blur_;
    CcdStage ccd_;
    VideoStage video_;
    ImageF rate_, e_, counts_;
    ImageU16 out_;
    double level_dc_ = 0.0;
    std::int64_t saturated_ = 0;
};

template <class Image>
bool sameBits(const Image& a, const Image& b) {
    for (int y = 0; y < a.height(); ++y)
        if (std::memcmp(a.row(y), b.row(y), sizeof(*a.row(y)) * a.width()) != 0) return false;
    return true;
}

void expectChainEqualsComposedStages(const CameraParams& cam) {
    const ImageF lpe = scene(cam);
    IiccdChain chain(cam, kSeed, test::configDir(), test::gammaTables());
    ComposedStages stages(cam);
    for (std::uint64_t k = 0; k < 3; ++k) {
        const FieldInfo& info = chain.process(lpe.cview());
        stages.field(lpe.cview(), k);
        SCOPED_TRACE("field " + std::to_string(k));
        EXPECT_TRUE(sameBits(chain.electrons(), stages.electrons()));
        EXPECT_TRUE(sameBits(chain.counts(), stages.counts()));
        EXPECT_TRUE(sameBits(chain.video(), stages.video()));
        EXPECT_EQ(info.level_dc, stages.level_dc());
        EXPECT_EQ(info.saturated_px, stages.saturated());
        EXPECT_GT(info.saturated_px, 0);  // the lamp blooms: the CCD's whole path is taken
    }
}

// Optics row by row inside the chain's band pass (no BSP, no halo).
TEST(ComposedStages, EqualTheChainBitForBit) {
    expectChainEqualsComposedStages(test::calibrationTube());
}

// Optics over the whole image first (BSP needs the cathode current; the halo spreads it).
TEST(ComposedStages, EqualTheChainBitForBitWithHaloAndBsp) {
    expectChainEqualsComposedStages(test::calibrationTube(
        {{"halo.enabled", "true"}, {"halo.fraction", "0.1"}, {"agc", "bsp"}}));
}

// With the lens's veiling glare (whole image first: its mean), alone and with halo and BSP.
TEST(ComposedStages, EqualTheChainBitForBitWithVeilingGlare) {
    expectChainEqualsComposedStages(
        test::calibrationTube({{"optics.veiling_glare_index", "0.03"}}));
    expectChainEqualsComposedStages(test::calibrationTube({{"optics.veiling_glare_index", "0.03"},
                                                           {"halo.enabled", "true"},
                                                           {"halo.fraction", "0.1"},
                                                           {"agc", "bsp"}}));
}

}  // namespace
}  // namespace nvs::sensor
