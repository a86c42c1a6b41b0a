#include "rt/camera_stage/camera_stage.h"

#include <cstring>

namespace nvs::rt {

IiccdCameraStage::IiccdCameraStage(const sensor::CameraParams& cam, const std::string& spectrum,
                                   std::uint64_t seed, Controls controls)
    : lpePerL_(spectrum == "pe" ? 1.0 : sensor::peRadiancePerBandRadiance(cam, spectrum)),
      chain_(cam, seed, sensor::ChainOptions{},
             controls == Controls::Preset ? sensor::ControlSource::Preset
                                          : sensor::ControlSource::Command),
      lpe_(lpePerL_ == 1.0 ? ImageF() : ImageF(cam.width, cam.height)) {}

void IiccdCameraStage::expose(const FrameRequest& req, ImageView<const float> radiance_W_m2_sr,
                              ImageView<std::uint16_t> counts, FrameMeta& meta) noexcept {
    const sensor::CameraParams& cam = chain_.camera();
    if (radiance_W_m2_sr.width() != cam.width || radiance_W_m2_sr.height() != cam.height ||
        counts.width() != cam.width || counts.height() != cam.height) {
        (void)chain_.process(ImageView<const float>{});  // reported as a size mismatch
        counts.fill(0);
        return;
    }
    // Band radiance → photoelectron radiance: Lpe = L·k (k = 1: the input already is Lpe).
    ImageView<const float> lpe = radiance_W_m2_sr;
    if (lpePerL_ != 1.0) {
        const float k = static_cast<float>(lpePerL_);
        for (int y = 0; y < cam.height; ++y) {
            const float* in = radiance_W_m2_sr.row(y);
            float* out = lpe_.view().row(y);
            for (int x = 0; x < cam.width; ++x)
                out[x] = in[x] * k;
        }
        lpe = lpe_.cview();
    }
    const PlatformState& p = req.platform;
    const sensor::CameraCommand cmd{p.gain_V, p.gate_s, p.gateMode, p.agc};
    const sensor::FieldInfo& info = chain_.process(lpe, cmd, req.t_sample_s);

    const std::size_t rowBytes = static_cast<std::size_t>(cam.width) * sizeof(std::uint16_t);
    for (int y = 0; y < cam.height; ++y)
        std::memcpy(counts.row(y), chain_.video().cview().row(y), rowBytes);
    // What the camera applied goes into the frame's metadata (the loop keeps it when
    // t_sample_s matches the request).
    meta.platform.t_sample_s = req.t_sample_s;
    meta.platform.gain_V = info.gain_V;
    meta.platform.gate_s = info.gate_s;
}

}  // namespace nvs::rt
