#include "rt/camera_stage/bolometer_stage.h"

#include "sim/core/image.h"

namespace nvs::rt {

BolometerCameraStage::BolometerCameraStage(const bolometer::ThermalCameraParams& cam, int bits,
                                           std::uint64_t seed, double startRadiance_W_m2_sr,
                                           const std::filesystem::path& configDir)
    : bits_(bits), chain_(cam, seed, configDir) {
    ImageF uniform(cam.width, cam.height);
    uniform.fill(static_cast<float>(startRadiance_W_m2_sr));
    for (int k = 0; k < 10000 && chain_.process(uniform.cview()).frozen; ++k) {
    }
}

void BolometerCameraStage::expose(const FrameRequest& req, RadianceFrame in,
                                  ImageView<std::uint16_t> counts, FieldMeta& applied) noexcept {
    const bolometer::FrameInfo& info = chain_.process(in.band_W_m2_sr);
    if (info.size_mismatch || counts.width() != chain_.camera().width ||
        counts.height() != chain_.camera().height) {
        counts.fill(0);
        return;
    }
    if (bits_ == 8) {
        const ImageU8& d = chain_.display();
        for (int y = 0; y < counts.height(); ++y) {
            const std::uint8_t* src = d.row(y);
            std::uint16_t* dst = counts.row(y);
            for (int x = 0; x < counts.width(); ++x)
                dst[x] = src[x];
        }
    } else {
        counts.copyFrom(chain_.raw().cview());
    }
    // No tube gain or gate: the metadata carries the exposure time only.
    applied.t_sample_s = req.t_sample_s;
    applied.gain_V = 0.0;
    applied.gate_s = 0.0;
}

}  // namespace nvs::rt
