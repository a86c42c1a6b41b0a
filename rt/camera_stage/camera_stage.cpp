#include "rt/camera_stage/camera_stage.h"

#include <algorithm>
#include <cstring>

namespace nvs::rt {

sensor::CameraParams IiccdCameraStage::autoParams(const sensor::CameraParams& cam) {
    sensor::CameraParams c = cam;
    if (c.agc == sensor::AgcMode::Off) c.agc = sensor::AgcMode::Agc;
    return c;
}

IiccdCameraStage::IiccdCameraStage(const sensor::CameraParams& cam, const std::string& spectrum,
                                   std::uint64_t seed, Controls controls,
                                   const std::filesystem::path& configDir,
                                   GammaTableCache& gammaTables)
    : cam_(cam),
      camAuto_(autoParams(cam)),
      controls_(controls),
      lpePerL_(spectrum == "pe" ? 1.0
                                : sensor::peRadiancePerBandRadiance(configDir, cam, spectrum)),
      optics_(cam_),
      gate_(cam_),
      cathode_(cam_, seed),
      bsp_(cam_),
      mcp_(cam_, seed, gammaTables),
      phosphor_(cam_),
      blur_(cam_, sensor::ChainOptions{}, configDir),
      ccd_(cam_, seed),
      videoStage_(cam_),
      agcPreset_(cam_),
      agcAuto_(camAuto_),
      lpe_(cam_.width, cam_.height),
      rate_(cam_.width, cam_.height),
      sig_(cam_.width, cam_.height),
      countsF_(cam_.width, cam_.height),
      video_(cam_.width, cam_.height) {
    // As IiccdChain: before the first field every row reads the video offset.
    countsF_.fill(static_cast<float>(std::clamp(cam_.video_offset_dc, 0.0, 65535.0)));
}

void IiccdCameraStage::expose(const FrameRequest& req, ImageView<const float> radiance_W_m2_sr,
                              ImageView<std::uint16_t> counts, FrameMeta& meta) noexcept {
    using sensor::AgcMode;
    info_ = sensor::FieldInfo{};
    info_.field = field_;
    if (radiance_W_m2_sr.width() != cam_.width || radiance_W_m2_sr.height() != cam_.height ||
        counts.width() != cam_.width || counts.height() != cam_.height) {
        info_.size_mismatch = true;
        counts.fill(0);
        return;
    }
    // Band radiance → photoelectron radiance: Lpe = L·k.
    const float k = static_cast<float>(lpePerL_);
    for (int y = 0; y < cam_.height; ++y) {
        const float* in = radiance_W_m2_sr.row(y);
        float* out = lpe_.view().row(y);
        for (int x = 0; x < cam_.width; ++x)
            out[x] = in[x] * k;
    }

    // Controls for this field.
    const PlatformState& p = req.platform;
    sensor::FieldContext ctx;
    ctx.field = field_;
    ctx.period_s = cam_.integrationPeriod_s();
    sensor::AgcLoop* loop = nullptr;  // the loop measuring this field, if any
    bool autogate = false;
    if (controls_ == Controls::Preset) {
        ctx.gain_V =
            cam_.agc == AgcMode::Off || cam_.agc == AgcMode::Bsp || cam_.agc == AgcMode::Autogate
                ? cam_.gain_V
                : agcPreset_.gain_V(field_);
        autogate = cam_.agc == AgcMode::Autogate;
        loop = &agcPreset_;
    } else {
        const AgcMode mode = camAuto_.agc;
        const bool gainLoop = p.agc && (mode == AgcMode::Agc || mode == AgcMode::Abc);
        autogate = mode == AgcMode::Autogate && (p.agc || p.gateMode == 2);
        if (gainLoop) {
            ctx.gain_V = agcAuto_.gain_V(field_);
        } else if (p.agc) {
            ctx.gain_V = cam_.gain_V;  // bsp / autogate: the tube gain stays at the preset's
        } else {
            ctx.gain_V = std::clamp(p.gain_V, 0.0, cam_.agc_max_gain_V);
        }
        if (gainLoop || autogate) loop = &agcAuto_;
    }

    // 1. optics
    info_.bad_input_px = optics_.apply(lpe_.cview(), rate_.view(), ctx);
    // 2. gate
    if (autogate) {
        const sensor::AgcLoop& l = controls_ == Controls::Preset ? agcPreset_ : agcAuto_;
        ctx.gate_s = gate_.gate_s(ctx.period_s, l.gateScale(field_));
    } else if (controls_ == Controls::Preset || p.gateMode == 1 || p.gateMode == 2) {
        ctx.gate_s = controls_ == Controls::Platform && p.gate_s > 0.0
                         ? std::clamp(p.gate_s, cam_.gate_min_s, ctx.period_s)
                         : gate_.gate_s(ctx.period_s, 1.0);
    } else {
        ctx.gate_s = ctx.period_s;  // continuous
    }
    // 3. photocathode
    cathode_.apply(rate_.cview(), sig_.view(), ctx);
    const double cathode_A = ctx.cathodeRate_pe_s * ctx.gate_s / ctx.period_s * 1.602176634e-19;
    // 4. bright-source protection, 5. MCP: G = (Vm/Vc)^g (eq. 6.1) times the BSP factor
    const double bspFactor = bsp_.factor(cathode_A);
    ctx.mcpGain = cam_.mcpGain(ctx.gain_V) * bspFactor;
    if (mcp_.enabled()) {
        mcp_.apply(sig_.view(), ctx);
    } else {
        ctx.mcpOut_e = ctx.cathodeRate_pe_s * ctx.gate_s;
    }
    // 6. phosphor, 7. blur, 8. CCD
    phosphor_.apply(sig_.view(), ctx);
    blur_.apply(sig_.view());
    info_.saturated_px = ccd_.apply(sig_.view(), ctx);
    // 9. video (this field's rows of the woven frame)
    info_.level_dc = videoStage_.apply(sig_.cview(), field_, countsF_.view(), video_.view());
    // 10. AGC loop: measures this field, commands field + lag
    if (loop != nullptr) loop->update(ctx, info_.level_dc);

    info_.t_sample_s = req.t_sample_s;
    info_.gain_V = ctx.gain_V;
    info_.mcp_gain = ctx.mcpGain;
    info_.gate_s = ctx.gate_s;
    info_.bsp_factor = bspFactor;
    info_.cathode_current_A = cathode_A;
    info_.screen_current_A = ctx.mcpOut_e * 1.602176634e-19 / ctx.period_s;
    info_.mean_pe = ctx.cathodeRate_pe_s * ctx.gate_s / (cam_.width * cam_.height);
    ++field_;

    const std::size_t rowBytes = static_cast<std::size_t>(cam_.width) * sizeof(std::uint16_t);
    for (int y = 0; y < cam_.height; ++y)
        std::memcpy(counts.row(y), video_.cview().row(y), rowBytes);
    // What the camera applied goes into the frame's metadata (the loop keeps it when
    // t_sample_s matches the request).
    meta.platform.t_sample_s = req.t_sample_s;
    meta.platform.gain_V = ctx.gain_V;
    meta.platform.gate_s = ctx.gate_s;
}

}  // namespace nvs::rt
