#include "rt/render_stage/render_stage.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "sim/core/error.h"

namespace nvs::rt {
std::unique_ptr<SceneRenderStage> SceneRenderStage::create(const Scenario& sc,
                                                           const DataDirs& dirs) {
    auto s = std::unique_ptr<SceneRenderStage>(new SceneRenderStage());
    s->sr_ = ScenarioRenderer::create(sc, dirs, sc.renderCoarse);
    const SceneSpec& rs = sc.scene;
    s->pool_ = std::make_unique<RowPool>(sc.renderThreads, sc.realtime);
    // "auto" times both primary passes here, on the first view with the loop's row pool.
    s->visibilityNote_ = s->sr_->renderer().choosePrimaryVisibility(*s->pool_);
    s->band_ = ImageF(sc.width, sc.height);
    s->holdRows_ = sc.fieldRowsOwn && sc.scan == ScanKind::Interlaced;
    if (s->holdRows_) {
        s->heldLpe_ = ImageF(sc.width, sc.height);
        s->heldBand_ = ImageF(sc.width, sc.height);
    }
    s->epochUnix_s_ = sc.utcStart_unix_s;
    if (sc.camera.thermal) {
        s->thermal_ = ThermalScene::forScenario(*s->sr_, dirs);
    }
    s->pose_ = PlatformPose(rs.site);
    const auto& lamps = s->sr_->scene().lamps;
    s->lampCount_ = static_cast<int>(std::min<std::size_t>(lamps.size(), 32));
    for (int i = 0; i < s->lampCount_; ++i) {
        if (lamps[static_cast<std::size_t>(i)].on) s->initialLamps_ |= 1u << i;
    }
    if (sc.channelIndex >= 0 && !sc.channels.empty()) s->setUpRig(sc);
    return s;
}

void SceneRenderStage::setUpRig(const Scenario& sc) {
    rig_ = true;
    sceneCamera_ = sr_->scene().camera;
    msg::RigMeta& m = rigMeta_;
    m.channel = sc.channelIndex;
    m.channels = static_cast<std::int32_t>(sc.channels.size());
    m.groundZ_m = sc.groundZ_m;
    for (std::size_t i = 0; i < sc.channels.size(); ++i) {
        const ChannelSpec& ch = sc.channels[i];
        mounts_[i] = ch.mount;
        pins_[i] = sr_->renderer().camera();  // until setRigPinholes
        std::snprintf(m.name[i], sizeof m.name[i], "%s", ch.name.c_str());
        // Its frames' first exposures start as the frame loop places them, moved by its skew.
        rigClock_.period_s[i] = ch.format.rate.period_s();
        rigClock_.first_s[i] =
            ch.faults.skew_s -
            exposureTiming(ch.format.rate, ch.format.scan, ch.format.exposure_s).firstLead_s;
    }
    rigClock_.channels = m.channels;
    const ChannelFaults& f = sc.channels[static_cast<std::size_t>(sc.channelIndex)].faults;
    misregistration_.yaw_rad = f.misregistration_rad[0];
    misregistration_.pitch_rad = f.misregistration_rad[1];
    misregistration_.roll_rad = f.misregistration_rad[2];
    for (int i = 0; i < 3; ++i)
        m.misregistration_rad[i] = f.misregistration_rad[i];
    m.skew_s = f.skew_s;
    base_ = sceneCamera_;
    published_ = mountedPose(base_, mounts_[sc.channelIndex]);
}

void SceneRenderStage::setRigPinholes(const render::PinholeCamera* pins, int count) noexcept {
    for (int i = 0; i < count && i < msg::kMaxChannels; ++i)
        pins_[i] = pins[i];
}

bool SceneRenderStage::poseRig(const PlatformState& p) noexcept {
    const scene::CameraPose base = p.poseFromTelemetry ? poseFor(p) : sceneCamera_;
    const scene::CameraPose published = mountedPose(base, mounts_[rigMeta_.channel]);
    const scene::CameraPose truePose =
        misregistration_.identity() ? published : mountedPose(published, misregistration_);
    if (!poseUsable(base) || !poseUsable(truePose)) return false;
    base_ = base;
    published_ = published;
    sr_->renderer().setCamera(truePose);
    return true;
}

void SceneRenderStage::publishRig(std::int64_t frame, FrameMeta& meta) const noexcept {
    // What a consumer registers with: the declared mountings, not a misregistered truth.
    const int own = rigMeta_.channel;
    meta.camera = cameraGeometry(published_, pins_[own]);
    meta.rig = rigMeta_;
    meta.rig.triggerCount = rigClock_.count(own, frame);
    // Every channel mounted on the platform camera's pose of this frame.
    for (int j = 0; j < rigMeta_.channels; ++j) {
        const msg::CameraGeometry peer =
            j == own ? meta.camera : cameraGeometry(mountedPose(base_, mounts_[j]), pins_[j]);
        meta.rig.valid[j] = groundHomography(meta.camera, peer, rigMeta_.groundZ_m, meta.rig.H[j]);
    }
}

bool SceneRenderStage::poseUsable(const scene::CameraPose& pose) noexcept {
    return PlatformPose::usable(pose);
}

scene::CameraPose SceneRenderStage::poseFor(const PlatformState& p) const noexcept {
    return pose_.poseFor(p);
}

void SceneRenderStage::render(const FrameRequest& req, RadianceTarget out,
                              FrameMeta& meta) noexcept {
    render::Renderer& r = sr_->renderer();
    double t_s =
        req.platform.utc_unix_s > 0.0 ? req.platform.utc_unix_s - epochUnix_s_ : req.t_sample_s;
    // Last line of defence (the telemetry is checked at its boundary, rt/telemetry): a time or
    // pose that is not finite never reaches Embree, whose ray queries assert on NaN. The last
    // good time and camera are kept instead, and the frame is counted.
    bool held = false;
    if (!std::isfinite(t_s)) {
        t_s = lastGoodT_s_;
        held = true;
    }
    lastGoodT_s_ = t_s;
    for (int i = 0; i < lampCount_; ++i)
        r.setLampOn(i, ((req.platform.lampMask >> i) & 1u) != 0);
    if (rig_) {
        if (!poseRig(req.platform)) held = true;  // the last camera kept
    } else if (req.platform.poseFromTelemetry) {
        const scene::CameraPose pose = poseFor(req.platform);
        if (poseUsable(pose)) {
            r.setCamera(pose);
        } else {
            held = true;  // the renderer keeps its last camera
        }
    }
    if (held) heldFrames_.fetch_add(1, std::memory_order_relaxed);
    if (thermal_) {
        (void)sr_->prepare(t_s);  // objects and time
        r.renderThermal(thermal_->frame(epochUnix_s_ + t_s), out.band_W_m2_sr, *pool_);
    } else if (holdRows_) {
        const int parity = heldValid_ ? req.rowParity : -1;
        sr_->renderFrame(t_s, heldLpe_.view(), heldBand_.view(), *pool_, parity);
        heldValid_ = true;
        out.lpe_pe_s_m2_sr.copyFrom(heldLpe_.cview());
        if (!out.band_W_m2_sr.empty()) out.band_W_m2_sr.copyFrom(heldBand_.cview());
    } else {
        const ImageView<float> band = out.band_W_m2_sr.empty() ? band_.view() : out.band_W_m2_sr;
        sr_->renderFrame(t_s, out.lpe_pe_s_m2_sr, band, *pool_);
    }
    // The camera's geometry (msg::CameraGeometry: OpenCV's axes, x right, y down, z forward).
    if (rig_) {
        publishRig(req.frame, meta);
    } else {
        Vec3 c, right, up, fwd;
        r.cameraAxes(&c, &right, &up, &fwd);
        meta.camera = cameraGeometry(c, right, up, fwd, r.camera());
    }
    const int n = r.truthBoxes(truth_, kMaxTruthBoxes);
    meta.truthCount = n;
    for (int i = 0; i < n; ++i) {
        const render::Renderer::ObjectTruth& t = truth_[i];
        TruthBox& b = meta.truth[i];
        b = TruthBox{t.id, t.x_px, t.y_px, t.w_px, t.h_px, t.visible, t.range_m, t.truncated};
        std::size_t k = 0;  // the class, cut to the field (the scene allows 15 characters)
        for (; k + 1 < sizeof b.cls && t.cls[k] != '\0'; ++k)
            b.cls[k] = t.cls[k];
        b.cls[k] = '\0';
    }
}

}  // namespace nvs::rt
