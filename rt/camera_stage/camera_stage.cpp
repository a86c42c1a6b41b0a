#include "rt/camera_stage/camera_stage.h"

namespace nvs::rt {

IiccdCameraStage::IiccdCameraStage(const sensor::CameraParams& cam, const std::string& spectrum,
                                   std::uint64_t seed, Controls controls,
                                   const std::filesystem::path& configDir,
                                   GammaTableCache& gammaTables)
    : lpePerL_(spectrum == "pe" ? 1.0
                                : sensor::peRadiancePerBandRadiance(configDir, cam, spectrum)),
      chain_(cam, seed, configDir, gammaTables, sensor::ChainOptions{},
             controls == Controls::Preset ? sensor::ControlSource::Preset
                                          : sensor::ControlSource::Command),
      lpe_(cam.width, cam.height) {}

void IiccdCameraStage::expose(const FrameRequest& req, RadianceFrame in,
                              ImageView<std::uint16_t> counts, FieldMeta& applied) noexcept {
    const sensor::CameraParams& cam = chain_.camera();
    // Photoelectron radiance as given, or band radiance converted: Lpe = L·k.
    const bool given = !in.lpe_pe_s_m2_sr.empty();
    const ImageView<const float> src = given ? in.lpe_pe_s_m2_sr : in.band_W_m2_sr;
    if (src.width() != cam.width || src.height() != cam.height || counts.width() != cam.width ||
        counts.height() != cam.height) {
        (void)chain_.process(ImageView<const float>{});  // reported as a size mismatch
        counts.fill(0);
        return;
    }
    ImageView<const float> lpe = src;
    if (!given) {
        const float k = static_cast<float>(lpePerL_);
        for (int y = 0; y < cam.height; ++y) {
            const float* px = src.row(y);
            float* out = lpe_.view().row(y);
            for (int x = 0; x < cam.width; ++x)
                out[x] = px[x] * k;
        }
        lpe = lpe_.cview();
    }
    const PlatformState& p = req.platform;
    const sensor::CameraCommand cmd{p.gain_V, p.gate_s, p.gateMode, p.agc};
    const sensor::FieldInfo& info = chain_.process(lpe, cmd, req.t_sample_s);

    counts.copyFrom(chain_.video().cview());
    // What the camera applied: the field's metadata.
    applied.t_sample_s = req.t_sample_s;
    applied.gain_V = info.gain_V;
    applied.gate_s = info.gate_s;
}

}  // namespace nvs::rt
