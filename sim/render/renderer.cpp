#include "sim/render/renderer.h"

#include <string>

#include "sim/render/render_impl.h"

// The renderer's outside: setup in order (Embree scene, light set-up, buffers, OpenGL), the
// per-frame setters, the frame's render as a sequence of the jobs (render_impl.h names the
// files that hold them) and the introspection for tests.

namespace nvs::render {

namespace {

// The G-buffer, the static data, the coarse nodes and weights, the per-frame coefficients.
void allocateBuffers(Renderer::Impl& im, const RenderConfig& config) {
    const std::size_t nm = im.materials.size();
    im.W = config.camera.width;
    im.H = config.camera.height;
    const std::size_t np = static_cast<std::size_t>(im.W) * im.H;
    im.gPos.assign(np * 3, 0.0f);
    im.gNrm.assign(np * 3, 0.0f);
    im.gSvf.assign(np, 0.0f);
    im.gMat.assign(np, kMiss);
    im.gObj.assign(np, -1);
    // Node arrays sized for the densest grid a later setCoarseFactor may ask for (f = 2).
    const int fMin = std::min(2, config.coarseFactor);
    const std::size_t maxNodes = static_cast<std::size_t>((im.W - 1) / fMin + 2) *
                                 static_cast<std::size_t>((im.H - 1) / fMin + 2);
    const std::size_t nl = im.lamps.size();
    if (nl > static_cast<std::size_t>(kMaxLampsStatic)) {
        throw SetupError("render: at most " + std::to_string(kMaxLampsStatic) + " lamps");
    }
    im.sValid.assign(np, 0);
    im.sLamp.assign(np * nl, 0.0f);
    im.sqMat.assign(np, kMiss);
    im.sqPos.assign(np * 3, 0.0f);
    im.sqNrm.assign(np * 3, 0.0f);
    im.sqSvf.assign(np, 0.0f);
    im.sqLamp.assign(np * nl, 0.0f);
    im.nodeRad.assign(maxNodes * kBands, 0.0f);
    im.uW.assign(np * 4, 0.0f);
    im.uKind.assign(np, 0);
    im.kMoon.assign(nm * kBands, 0.0f);
    im.kSky.assign(nm * kBands, 0.0f);
    im.kSpec.assign(nm * kBands, 0.0f);
    im.kLamp.assign(nl * nm * kBands, 0.0f);
    im.skyTab.assign(static_cast<std::size_t>(kBands) * kSkyZ * kSkyA, 0.0f);
}

}  // namespace

Renderer::Renderer(const scene::Scene& sc, const RenderConfig& config)
    : config_(config), impl_(std::make_unique<Impl>()) {
    sc.validate();
    if (config.coarseFactor < 1 || config.coarseFactor > 16) {
        throw SetupError("render: coarse factor must lie in 1..16");
    }
    if (config.camera.width < 1 || config.camera.height < 1) {
        throw SetupError("render: image size must be positive");
    }
    Impl& im = *impl_;
    im.materials = sc.materials;
    createEmbreeScene(im, sc, config);
    lampOn_.assign(sc.lamps.size(), true);
    for (std::size_t l = 0; l < sc.lamps.size(); ++l)
        lampOn_[l] = sc.lamps[l].on;
    setTime(0.0);
    setCamera(sc.camera);
    sourceMaterialCoefficients(sc, config, &rhoMoon_, &rhoNight_);
    setUpLamps(im, sc, config);
    computeSkyViewFactors(im, config);
    allocateBuffers(im, config);
    setCoarseFactor(config.coarseFactor);
    if (config.primaryVisibility != PrimaryVisibility::kEmbree) setUpGl(im, config);
}

Renderer::~Renderer() = default;

void Renderer::setCoarseFactor(int f) noexcept {
    coarse_ = std::clamp(f, 1, config_.coarseFactor);
    Impl& im = *impl_;
    im.nodeW = (im.W - 1) / coarse_ + 2;
    im.nodeH = (im.H - 1) / coarse_ + 2;
}

void Renderer::setCamera(const scene::CameraPose& p) noexcept {
    Impl& im = *impl_;
    im.gValidRows = 0;
    im.camPos = p.position_m;
    im.camFwd = normalized(p.target_m - p.position_m);
    Vec3 right = cross(im.camFwd, p.up);
    if (!(norm(right) > 1e-9)) right = {1, 0, 0};
    right = normalized(right);
    Vec3 up = cross(right, im.camFwd);
    // Twist: rotation of the image about the line of sight.
    const double ct = std::cos(p.twist_rad), st = std::sin(p.twist_rad);
    im.camRight = right * ct + up * st;
    im.camUp = up * ct - right * st;
}

double Renderer::skyViewFactor(int object, int triangle, double u, double v, bool back) const {
    const auto& s = impl_->objects[static_cast<std::size_t>(object)].svf;
    const std::size_t base = static_cast<std::size_t>(triangle) * 6 + (back ? 3 : 0);
    return (1.0 - u - v) * static_cast<double>(s[base]) + u * static_cast<double>(s[base + 1]) +
           v * static_cast<double>(s[base + 2]);
}

double Renderer::lampCoefficient(int lamp, int material, int band) const {
    return impl_->lamps[static_cast<std::size_t>(lamp)].coef[idx(material, band)];
}

bool Renderer::pixelHit(int x, int y, Vec3* p, int* material, int* object) const noexcept {
    const Impl& im = *impl_;
    const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
    if (im.gMat[i] == kMiss) return false;
    *p = g3(im.gPos, i);
    *material = im.gMat[i];
    *object = im.gObj[i];
    return true;
}

void Renderer::render(const FrameSky& sky, ImageView<float> pe, ImageView<float> bandW,
                      RowExecutor& exec, int rowParity) noexcept {
    Impl& im = *impl_;
    if (pe.width() != im.W || pe.height() != im.H || bandW.width() != im.W ||
        bandW.height() != im.H) {
        return;
    }
    if (im.autoPending) decideAuto(im, config_, exec);
    im.primary = 0;
    im.shadow = 0;
    im.secondary = 0;
    frameCoefficients(im, config_, sky, terms_, lampOn_, rhoMoon_, rhoNight_);
    const bool moonOn = sky.moonUp && (terms_ & kTermMoon);
    Ctx c{&im,
          &config_,
          &sky,
          pe,
          bandW,
          coarse_,
          terms_,
          moonOn,
          im.uFactor != coarse_,
          rowStep(im.H),
          rowStep(im.nodeH)};
    frameSkyInView(im, sky, c);
    const int parity = rowParity >= 0 && coarse_ == 1 ? (rowParity & 1) : -1;
    updateGeometryBuffer(c, parity, exec);
    c.rowParity = parity;
    c.shadeCount = parity < 0 ? im.H : (im.H - parity + 1) / 2;
    c.rowStepShade = rowStep(c.shadeCount);
    if (coarse_ > 1) {
        exec.run(im.nodeH, &nodeRows, &c);
        exec.run(im.H, &upsampleRows, &c);
        im.uFactor = coarse_;
    } else {
        exec.run(c.shadeCount, &shadeRows, &c);
    }
    drawPointSources(im, config_, sky, lampOn_, terms_, parity, pe, bandW);
    stats_.primaryRays = im.primary;
    stats_.shadowRays = im.shadow;
    stats_.secondaryRays = im.secondary;
}

int Renderer::truthBoxes(int* ids, float* xywh, int maxBoxes) const noexcept {
    const Impl& im = *impl_;
    const PinholeCamera& cam = config_.camera;
    int n = 0;
    for (const ObjectData& od : im.objects) {
        if (od.obj->trackId < 0 || n >= maxBoxes) continue;
        double x0 = 1e30, y0 = 1e30, x1 = -1e30, y1 = -1e30;
        bool any = false;
        for (std::size_t i = 0; i < od.obj->mesh.vertexCount(); ++i) {
            const Vec3 d = toV(od.vbuf[i]) - im.camPos;
            const double zf = dot(d, im.camFwd);
            if (zf <= 1e-3) continue;
            const double u =
                dot(d, im.camRight) / zf * cam.focalLength_m / cam.pitchX_m + 0.5 * cam.width;
            const double v =
                -dot(d, im.camUp) / zf * cam.focalLength_m / cam.pitchY_m + 0.5 * cam.height;
            x0 = std::min(x0, u), x1 = std::max(x1, u), y0 = std::min(y0, v), y1 = std::max(y1, v);
            any = true;
        }
        if (!any) continue;
        x0 = std::max(x0, 0.0), y0 = std::max(y0, 0.0);
        x1 = std::min(x1, static_cast<double>(cam.width)),
        y1 = std::min(y1, static_cast<double>(cam.height));
        if (x1 <= x0 || y1 <= y0) continue;
        ids[n] = od.obj->trackId;
        xywh[4 * n] = static_cast<float>(x0);
        xywh[4 * n + 1] = static_cast<float>(y0);
        xywh[4 * n + 2] = static_cast<float>(x1 - x0);
        xywh[4 * n + 3] = static_cast<float>(y1 - y0);
        ++n;
    }
    return n;
}

bool Renderer::pixelSurface(int x, int y, Vec3* normal, double* skyViewFactor) const noexcept {
    const Impl& im = *impl_;
    const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
    if (im.gMat[i] == kMiss) return false;
    *normal = g3(im.gNrm, i);
    *skyViewFactor = im.gSvf[i];
    return true;
}

}  // namespace nvs::render
