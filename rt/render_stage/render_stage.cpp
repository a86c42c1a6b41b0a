#include "rt/render_stage/render_stage.h"

#include <cmath>

#include "sim/core/error.h"
#include "sim/core/geometry.h"
#include "sim/core/units.h"

namespace nvs::rt {
namespace {

// WGS84 (NIMA TR8350.2).
constexpr double kWgs84A_m = 6378137.0;
constexpr double kWgs84E2 = 6.69437999014e-3;

}  // namespace

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
    s->lat0_rad_ = rs.site.lat_deg * kRadPerDeg;
    s->lon0_rad_ = rs.site.lon_deg * kRadPerDeg;
    s->h0_m_ = rs.site.height_m;
    const double sl = std::sin(s->lat0_rad_);
    const double w = std::sqrt(1.0 - kWgs84E2 * sl * sl);
    s->primeVerticalRadius_m_ = kWgs84A_m / w;
    s->meridianRadius_m_ = kWgs84A_m * (1.0 - kWgs84E2) / (w * w * w);
    const auto& lamps = s->sr_->scene().lamps;
    s->lampCount_ = static_cast<int>(std::min<std::size_t>(lamps.size(), 32));
    for (int i = 0; i < s->lampCount_; ++i) {
        if (lamps[static_cast<std::size_t>(i)].on) s->initialLamps_ |= 1u << i;
    }
    return s;
}

bool SceneRenderStage::poseUsable(const scene::CameraPose& pose) noexcept {
    // Finite, and within 10⁸ m of the scene origin: beyond that the ray arithmetic in single
    // precision loses the scene entirely (and the telemetry bounds allow 10⁶ m of altitude).
    constexpr double kMaxDistance_m = 1e8;
    for (const Vec3& v : {pose.position_m, pose.target_m, pose.up}) {
        for (const double c : {v.x, v.y, v.z}) {
            if (!(std::fabs(c) <= kMaxDistance_m)) return false;
        }
    }
    return true;
}

scene::CameraPose SceneRenderStage::poseFor(const PlatformState& p) const noexcept {
    scene::CameraPose pose;
    const double east = (p.lon_deg * kRadPerDeg - lon0_rad_) * (primeVerticalRadius_m_ + h0_m_) *
                        std::cos(lat0_rad_);
    const double north = (p.lat_deg * kRadPerDeg - lat0_rad_) * (meridianRadius_m_ + h0_m_);
    pose.position_m = {east, north, p.alt_m - h0_m_};
    const Mat3 enuFromBody = enuFromNed() * nedFromBodyYpr(p.yaw_rad, p.pitch_rad, p.roll_rad);
    const Vec3 forward_enu = enuFromBody * Vec3{1.0, 0.0, 0.0};
    pose.target_m = pose.position_m + forward_enu;
    pose.up = enuFromBody * Vec3{0.0, 0.0, -1.0};
    pose.twist_rad = 0.0;
    return pose;
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
    if (req.platform.poseFromTelemetry) {
        const scene::CameraPose pose = poseFor(req.platform);
        if (poseUsable(pose)) {
            r.setCamera(pose);
        } else {
            held = true;  // the renderer keeps its last camera
        }
    }
    if (held) heldFrames_.fetch_add(1, std::memory_order_relaxed);
    const render::FrameSky sky = sr_->prepare(t_s);
    if (holdRows_) {
        const int parity = heldValid_ ? req.rowParity : -1;
        r.render(sky, heldLpe_.view(), heldBand_.view(), *pool_, parity);
        heldValid_ = true;
        out.lpe_pe_s_m2_sr.copyFrom(heldLpe_.cview());
        if (!out.band_W_m2_sr.empty()) out.band_W_m2_sr.copyFrom(heldBand_.cview());
    } else {
        const ImageView<float> band = out.band_W_m2_sr.empty() ? band_.view() : out.band_W_m2_sr;
        r.render(sky, out.lpe_pe_s_m2_sr, band, *pool_);
    }
    const int n = r.truthBoxes(ids_, boxes_, kMaxTruthBoxes);
    meta.truthCount = n;
    for (int i = 0; i < n; ++i) {
        meta.truth[i] = TruthBox{ids_[i], boxes_[4 * i], boxes_[4 * i + 1], boxes_[4 * i + 2],
                                 boxes_[4 * i + 3]};
    }
}

}  // namespace nvs::rt
