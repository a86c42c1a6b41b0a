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
    scene::cameraAxes(p, &im.camFwd, &im.camRight, &im.camUp);
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

namespace {
// The visible fraction of a tracked object (Renderer::ObjectTruth::visible): samples on every
// triangle (both sides: a back face's ray meets the object's front first, which counts as seen,
// so the fraction does not depend on the mesh's winding), each seen when the first hit along
// the camera's ray is this object, weighted by its projected solid angle.
double visibleFraction(const Renderer::Impl& im, const ObjectData& od,
                       const PinholeCamera& cam) noexcept {
    const double W = cam.width, H = cam.height;
    const std::vector<std::uint32_t>& tri = od.obj->mesh.triangles;
    double seen = 0.0, total = 0.0;
    for (std::size_t k = 0; k + 2 < tri.size(); k += 3) {
        const Vec3 a = toV(od.vbuf[tri[k]]), b = toV(od.vbuf[tri[k + 1]]),
                   c = toV(od.vbuf[tri[k + 2]]);
        const Vec3 cr = cross(b - a, c - a);
        const double area = 0.5 * norm(cr);
        if (!(area > 0.0)) continue;
        const Vec3 nrm = cr * (0.5 / area);
        // Subdivision from the triangle's longest edge in the image (at its centroid's
        // distance): about one sample per 12 px of edge, 1 … 6 per edge.
        const double dist = norm((a + b + c) * (1.0 / 3.0) - im.camPos);
        const double edge_m = std::max({norm(b - a), norm(c - b), norm(a - c)});
        const double edge_px = edge_m / std::max(dist, 1e-3) * cam.focalLength_m / cam.pitchX_m;
        const int m = std::clamp(static_cast<int>(std::ceil(edge_px / 12.0)), 1, 6);
        const double subArea = area / (m * m);
        // The m² sub-triangles' centroids in barycentric steps of 1/m: the upright ones
        // (i + j ≤ m − 1) at ((i + 1/3), (j + 1/3))/m, the inverted ones at ((i + 2/3),
        // (j + 2/3))/m (i + j ≤ m − 2).
        for (int i = 0; i < m; ++i) {
            for (int j = 0; i + j < m; ++j) {
                for (int up = 0; up < 2 && (up == 0 || i + j <= m - 2); ++up) {
                    const double o = up == 0 ? 1.0 / 3.0 : 2.0 / 3.0;
                    const Vec3 q = a + (b - a) * ((i + o) / m) + (c - a) * ((j + o) / m);
                    double u = 0.0, v = 0.0;
                    if (!im.project(q, cam, &u, &v) || u < 0.0 || v < 0.0 || u >= W || v >= H)
                        continue;
                    const Vec3 d = q - im.camPos;
                    const double r = norm(d);
                    const Vec3 dir = d * (1.0 / r);
                    const double w = subArea * std::fabs(dot(nrm, dir)) / (r * r);
                    total += w;
                    RTCRayHit rh;
                    // A first hit this object's, or none before the sample (a ray that grazes
                    // the triangle's own edge), counts as seen.
                    if (!im.intersect(im.camPos, dir, &rh) || rh.hit.geomID == od.geomId ||
                        rh.ray.tfar > static_cast<float>(r * (1.0 - 1e-5))) {
                        seen += w;
                    }
                }
            }
        }
    }
    return total > 0.0 ? seen / total : 0.0;
}
}  // namespace

int Renderer::truthBoxes(ObjectTruth* out, int maxBoxes) const noexcept {
    const Impl& im = *impl_;
    const PinholeCamera& cam = config_.camera;
    const double W = cam.width, H = cam.height;
    int n = 0;
    for (const ObjectData& od : im.objects) {
        if (od.obj->trackId < 0 || n >= maxBoxes) continue;
        const std::size_t nv = od.obj->mesh.vertexCount();
        double x0 = 1e30, y0 = 1e30, x1 = -1e30, y1 = -1e30;
        bool any = false, behind = false;
        Vec3 centroid{0.0, 0.0, 0.0};
        for (std::size_t i = 0; i < nv; ++i) {
            const Vec3 q = toV(od.vbuf[i]);
            centroid = centroid + q;
            double u = 0.0, v = 0.0;
            if (!im.project(q, cam, &u, &v, 1e-3)) {  // 1 mm in front, as the box always had
                behind = true;
                continue;
            }
            x0 = std::min(x0, u), x1 = std::max(x1, u), y0 = std::min(y0, v), y1 = std::max(y1, v);
            any = true;
        }
        if (!any) continue;
        ObjectTruth t;
        t.truncated = behind || x0 < 0.0 || y0 < 0.0 || x1 > W || y1 > H;
        x0 = std::max(x0, 0.0), y0 = std::max(y0, 0.0);
        x1 = std::min(x1, W), y1 = std::min(y1, H);
        if (x1 <= x0 || y1 <= y0) continue;
        t.id = od.obj->trackId;
        t.cls = od.obj->truthClass.c_str();
        t.x_px = static_cast<float>(x0);
        t.y_px = static_cast<float>(y0);
        t.w_px = static_cast<float>(x1 - x0);
        t.h_px = static_cast<float>(y1 - y0);
        t.range_m =
            static_cast<float>(norm(centroid * (1.0 / static_cast<double>(nv)) - im.camPos));
        t.visible = static_cast<float>(visibleFraction(im, od, cam));
        out[n++] = t;
    }
    return n;
}

void Renderer::cameraAxes(Vec3* position_m, Vec3* right, Vec3* up, Vec3* forward) const noexcept {
    const Impl& im = *impl_;
    *position_m = im.camPos;
    *right = im.camRight;
    *up = im.camUp;
    *forward = im.camFwd;
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
