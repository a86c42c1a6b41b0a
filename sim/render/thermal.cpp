// The thermal band (renderer.h, docs/thermal.md "Rendering"): the scene's faces grouped into
// surface classes for the heat balance, the Sun's shadows on them, and the per-frame band
// radiance at the aperture from the shared G-buffer.
#include <algorithm>
#include <cmath>
#include <map>

#include "sim/render/render_impl.h"

namespace nvs::render {
namespace {

constexpr int kTilts = 5, kAzimuths = 4, kSkyViews = 4;
constexpr int kKeysPerMaterial = kTilts * kAzimuths * kSkyViews;
constexpr int kMaxThermalViewWidth = 8192;  // a row's scratch on the stack

// Tilt band of a unit normal: 0 facing up (< 22.5° from the zenith) … 2 vertical … 4 down; the
// bands' edges at 22.5°, 67.5°, 112.5° and 157.5° as cosines (no acos per pixel).
int tiltBand(double nz) noexcept {
    constexpr double kCos22 = 0.92387953251128674, kCos67 = 0.38268343236508978;
    return static_cast<int>(nz <= kCos22) + static_cast<int>(nz <= kCos67) +
           static_cast<int>(nz <= -kCos67) + static_cast<int>(nz <= -kCos22);
}

// Azimuth quadrant of an inclined normal, from north through east (x east, y north): 0 N for
// azimuths in [−45°, 45°), 1 E in [45°, 135°), 2 S in [135°, 225°), 3 W in [225°, 315°); 0 for the
// up and down bands. By comparisons of the components, without branches (no atan2 per pixel).
int azimuthQuadrant(const Vec3& n, int tilt) noexcept {
    const double e = n.x, no = n.y;
    const bool north = (no > 0.0) & (-no <= e) & (e < no);
    const bool east = (e > 0.0) & (-e < no) & (no <= e);
    const bool south = (no < 0.0) & (no < e) & (e <= -no);
    const int q = north ? 0 : east ? 1 : south ? 2 : 3;
    return (tilt == 0) | (tilt == kTilts - 1) ? 0 : q;
}

int skyViewBand(double svf) noexcept {
    return std::clamp(static_cast<int>(svf * kSkyViews), 0, kSkyViews - 1);
}

int classKey(int material, const Vec3& n, double svf) noexcept {
    const int tilt = tiltBand(n.z);
    return ((material * kTilts + tilt) * kAzimuths + azimuthQuadrant(n, tilt)) * kSkyViews +
           skyViewBand(svf);
}

// How far apart two keys of one material are (tilt bands weigh most), for keys no face has.
double keyDistance(int a, int b) noexcept {
    const int sa = a % kSkyViews, sb = b % kSkyViews;
    const int aa = (a / kSkyViews) % kAzimuths, ab = (b / kSkyViews) % kAzimuths;
    const int ta = (a / (kSkyViews * kAzimuths)) % kTilts;
    const int tb = (b / (kSkyViews * kAzimuths)) % kTilts;
    return 4.0 * std::abs(ta - tb) + (aa == ab ? 0.0 : 1.0) + 0.5 * std::abs(sa - sb);
}

struct Accumulator {
    Vec3 normalArea{0.0, 0.0, 0.0};
    double svfArea = 0.0, area = 0.0;
    std::vector<Vec3> centroids;
};

// Every face of every triangle (both sides) into its class's accumulator.
std::map<int, Accumulator> gatherFaces(const Renderer::Impl& im) {
    std::map<int, Accumulator> acc;
    for (const ObjectData& od : im.objects) {
        const scene::Mesh& mesh = od.obj->mesh;
        for (std::size_t t = 0; t < mesh.triangleCount(); ++t) {
            const Vec3 a = toV(od.vbuf[mesh.triangles[3 * t]]);
            const Vec3 b = toV(od.vbuf[mesh.triangles[3 * t + 1]]);
            const Vec3 c = toV(od.vbuf[mesh.triangles[3 * t + 2]]);
            const Vec3 cr = cross(b - a, c - a);
            const double area = 0.5 * norm(cr);
            if (!(area > 0.0)) continue;
            const Vec3 n = cr * (0.5 / area);
            const Vec3 centroid = (a + b + c) * (1.0 / 3.0);
            for (int side = 0; side < 2; ++side) {
                const Vec3 ns = side == 0 ? n : n * -1.0;
                double svf = 0.0;
                for (int k = 0; k < 3; ++k)
                    svf += static_cast<double>(
                               od.svf[t * 6 + static_cast<std::size_t>(side * 3 + k)]) /
                           3.0;
                Accumulator& e = acc[classKey(od.material[t], ns, svf)];
                e.normalArea = e.normalArea + ns * area;
                e.svfArea += svf * area;
                e.area += area;
                e.centroids.push_back(centroid + ns * kEps_m);
            }
        }
    }
    return acc;
}

ThermalSurface finishClass(int key, const Accumulator& e, int maxSamples) {
    ThermalSurface s;
    s.key = key;
    s.material = key / kKeysPerMaterial;
    const double len = norm(e.normalArea);
    s.normal = len > 0.0 ? e.normalArea * (1.0 / len) : Vec3{0.0, 0.0, 1.0};
    s.tilt_rad = std::acos(std::clamp(s.normal.z, -1.0, 1.0));
    s.azimuth_rad = std::atan2(s.normal.x, s.normal.y);
    if (s.azimuth_rad < 0.0) s.azimuth_rad += kTwoPi;
    s.skyView = e.area > 0.0 ? e.svfArea / e.area : 1.0;
    s.area_m2 = e.area;
    const std::size_t n = e.centroids.size();
    const std::size_t take = std::min<std::size_t>(n, static_cast<std::size_t>(maxSamples));
    for (std::size_t i = 0; i < take; ++i)
        s.samples_m.push_back(e.centroids[i * n / take]);
    return s;
}

inline float lerpTable(const float* t, int n, double x) noexcept {
    if (x <= 0.0) return t[0];
    if (x >= n - 1) return t[n - 1];
    const int i = static_cast<int>(x);
    const float f = static_cast<float>(x - i);
    return t[i] + f * (t[i + 1] - t[i]);
}

struct ThermalCtx {
    Renderer::Impl* im;
    const RenderConfig* cfg;
    const ThermalFrame* f;
    ImageView<float> out;
};

float skyAt(const ThermalFrame& f, double dirZ) noexcept {
    if (dirZ <= 0.0) return static_cast<float>(f.groundRadiance);
    const double zenith_deg = std::acos(std::min(dirZ, 1.0)) * (180.0 / kPi);
    return lerpTable(f.skyRadiance, f.skyCount, zenith_deg / 90.0 * (f.skyCount - 1));
}

// A thermal-view pixel's primary hit: from the G-buffer pixel it shares, or its own ray.
struct ViewHit {
    bool hit = false;
    Vec3 p, n;
    int material = 0;
    double svf = 0.0;
};

ViewHit viewHit(const ThermalCtx& c, const Vec3& dir, std::int32_t src) noexcept {
    const Renderer::Impl& im = *c.im;
    ViewHit h;
    if (src >= 0) {
        const std::size_t i = static_cast<std::size_t>(src);
        if (im.gMat[i] == kMiss) return h;
        h.hit = true;
        h.p = g3(im.gPos, i);
        h.n = g3(im.gNrm, i);
        h.material = im.gMat[i];
        h.svf = im.gSvf[i];
        return h;
    }
    RTCRayHit rh;
    if (!im.intersect(im.camPos, dir, &rh)) return h;
    h.hit = true;
    hitFields(im, rh.hit.geomID, rh.hit.primID, rh.hit.u, rh.hit.v,
              static_cast<double>(rh.ray.tfar), Vec3{rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z},
              im.camPos, dir, &h.p, &h.n, &h.material, &h.svf);
    return h;
}

// The classes a pixel's temperature comes from: its key's class, and the class of the
// neighbouring sky-view band toward its own sky-view factor with the weight between them, linear
// in the classes' mean sky-view factors (a surface whose sky view changes across it has no steps
// at the bands' edges).
void pixelClasses(const Renderer::Impl::ThermalKey& k, double svf, int band, std::int32_t* cls1,
                  float* w) noexcept {
    const bool below = svf * kSkyViews - band < 0.5;
    const std::int32_t c1 = below ? k.below : k.above;
    const float inv = below ? k.invBelow : k.invAbove;
    *cls1 = c1;
    *w = c1 < 0 ? 0.0f : std::clamp((static_cast<float>(svf) - k.skyView) * inv, 0.0f, 1.0f);
}

// What view pixel (x, y) takes from its hit and the frame's fixed tables (Impl::ThermalPixel).
// range_m, lnRange: of a shared hit (thermalPixelRows computes them a row at a time).
Renderer::Impl::ThermalPixel thermalPixel(const ThermalCtx& c, int x, int y, double range_m,
                                          double lnRange) noexcept {
    const Renderer::Impl& im = *c.im;
    const ThermalFrame& f = *c.f;
    const std::int32_t src = im.thermalSrc[static_cast<std::size_t>(y) * im.thermalView.width + x];
    const bool shared = src >= 0 && im.gMat[static_cast<std::size_t>(src)] != kMiss;
    // The view's own ray: for a pixel outside the G-buffer, and for the sky's direction.
    const Vec3 dir = shared ? Vec3{} : im.pixelDir(x + 0.5, y + 0.5, im.thermalView);
    const ViewHit h = viewHit(c, dir, src);
    Renderer::Impl::ThermalPixel p;
    if (!h.hit) {  // the sky at its zenith angle; the surroundings below it
        p.envSky = dir.z > 0.0 ? skyAt(f, dir.z) : 0.0f;
        p.envGround = dir.z > 0.0 ? 0.0f : 1.0f;
        return p;
    }
    const Vec3 d = h.p - im.camPos;
    const double r = shared ? range_m : std::max(norm(d), 1e-3);
    const Vec3 view = d * (-1.0 / r);
    const double k = ((shared ? lnRange : std::log(r)) - f.lnRange0) / f.lnRangeStep;
    p.tau = lerpTable(f.pathTau, f.rangeCount, k);
    p.path = lerpTable(f.pathRadiance, f.rangeCount, k);
    const int band = skyViewBand(h.svf);
    const Renderer::Impl::ThermalKey& key =
        im.thermalKeys[static_cast<std::size_t>(classKey(h.material, h.n, h.svf))];
    p.cls0 = key.cls;
    if (p.cls0 < 0) {  // a material without a class: the air's temperature, black
        p.envGround = 1.0f;
        return p;
    }
    pixelClasses(key, h.svf, band, &p.cls1, &p.w);
    const double cosT = std::clamp(dot(h.n, view), 0.0, 1.0);
    const float* eps = f.emissivity + static_cast<std::size_t>(p.cls0) * kThermalCosBins;
    p.eps = lerpTable(eps, kThermalCosBins, cosT * (kThermalCosBins - 1));
    // L_env = s·L_mirror + (1 − s)·(F·L_sky,diffuse + (1 − F)·B(T_air)), its sky and air parts.
    const double s = key.specularity;
    const Vec3 mirror = h.n * (2.0 * cosT) - view;
    const bool mirrorUp = mirror.z > 0.0;
    const double mirrorSky =
        mirrorUp && s > 0.0 ? s * static_cast<double>(skyAt(f, mirror.z)) : 0.0;
    p.envSky = static_cast<float>(mirrorSky + (1.0 - s) * h.svf * f.skyDiffuse);
    p.envGround = static_cast<float>((mirrorUp ? 0.0 : s) + (1.0 - s) * (1.0 - h.svf));
    return p;
}

// A row at a time in passes, each a short loop whose pixels the processor overlaps: the range
// of each shared hit, its logarithm, then the rest (one loop of all three per pixel waits on
// the square root and the logarithm in turn: 55 ns a pixel against ... below).
void thermalPixelRows(void* arg, int y0, int y1) noexcept {
    const ThermalCtx& c = *static_cast<const ThermalCtx*>(arg);
    const Renderer::Impl& im = *c.im;
    const int w = im.thermalView.width;
    double range_m[kMaxThermalViewWidth], lnRange[kMaxThermalViewWidth];
    for (int y = y0; y < y1; ++y) {
        const std::int32_t* src = &im.thermalSrc[static_cast<std::size_t>(y) * w];
        for (int x = 0; x < w; ++x) {
            const std::size_t i = static_cast<std::size_t>(src[x] < 0 ? 0 : src[x]);
            range_m[x] = src[x] >= 0 && im.gMat[i] != kMiss
                             ? std::max(norm(g3(im.gPos, i) - im.camPos), 1e-3)
                             : 1.0;
        }
        for (int x = 0; x < w; ++x)
            lnRange[x] = std::log(range_m[x]);
        Renderer::Impl::ThermalPixel* out = &c.im->thermalPx[static_cast<std::size_t>(y) * w];
        for (int x = 0; x < w; ++x)
            out[x] = thermalPixel(c, x, y, range_m[x], lnRange[x]);
    }
}

// Per frame: L = τ·(ε·B(T) + (1 − ε)·(L_sky + a·B(T_air))) + L_path, T between the classes.
void thermalRows(void* arg, int y0, int y1) noexcept {
    const ThermalCtx& c = *static_cast<const ThermalCtx*>(arg);
    const Renderer::Impl& im = *c.im;
    const ThermalFrame& f = *c.f;
    const float air = static_cast<float>(f.groundRadiance);
    const float t0 = static_cast<float>(f.blackbodyT0_K);
    const float perK = static_cast<float>(1.0 / f.blackbodyStep_K);
    for (int y = y0; y < y1; ++y) {
        float* row = c.out.row(y);
        const int w = im.thermalView.width;
        const Renderer::Impl::ThermalPixel* px = &im.thermalPx[static_cast<std::size_t>(y) * w];
        for (int x = 0; x < w; ++x) {
            const Renderer::Impl::ThermalPixel& p = px[x];
            float b = 0.0f;
            if (p.cls0 >= 0) {
                float t = f.surfaceTemperature_K[p.cls0];
                if (p.cls1 >= 0) t += p.w * (f.surfaceTemperature_K[p.cls1] - t);
                b = lerpTable(f.blackbody, f.blackbodyCount, static_cast<double>((t - t0) * perK));
            }
            const float env = p.envSky + p.envGround * air;
            row[x] = p.tau * (p.eps * b + (1.0f - p.eps) * env) + p.path;
        }
    }
}

}  // namespace

const std::vector<ThermalSurface>& Renderer::prepareThermal(int maxSamples) {
    Impl& im = *impl_;
    im.thermal.clear();
    const std::map<int, Accumulator> acc = gatherFaces(im);
    for (const auto& [key, e] : acc)
        im.thermal.push_back(finishClass(key, e, std::max(maxSamples, 1)));
    setThermalView(config_.camera);
    const std::size_t keys = im.materials.size() * kKeysPerMaterial;
    std::vector<std::int32_t> classOfKey(keys, -1);
    for (std::size_t k = 0; k < keys; ++k) {
        double best = 1e30;
        for (std::size_t s = 0; s < im.thermal.size(); ++s) {
            const int key = im.thermal[s].key;
            if (key / kKeysPerMaterial != static_cast<int>(k) / kKeysPerMaterial) continue;
            const double dist = keyDistance(key, static_cast<int>(k));
            if (dist < best) best = dist, classOfKey[k] = static_cast<std::int32_t>(s);
        }
    }
    im.thermalKeys.assign(keys, Impl::ThermalKey{});
    for (std::size_t k = 0; k < keys; ++k) {
        Impl::ThermalKey& e = im.thermalKeys[k];
        e.cls = classOfKey[k];
        e.specularity = static_cast<float>(im.materials[k / kKeysPerMaterial].specularity);
        if (e.cls < 0) continue;
        e.skyView = static_cast<float>(im.thermal[static_cast<std::size_t>(e.cls)].skyView);
        // The neighbouring bands' classes (the same material, tilt and azimuth).
        const int band = static_cast<int>(k % kSkyViews);
        for (const int other : {band - 1, band + 1}) {
            if (other < 0 || other >= kSkyViews) continue;
            const std::int32_t c1 = classOfKey[k - band + other];
            if (c1 < 0 || c1 == e.cls) continue;
            const double s1 = im.thermal[static_cast<std::size_t>(c1)].skyView;
            const double ds = s1 - static_cast<double>(e.skyView);
            if (std::fabs(ds) < 1e-3) continue;
            (other < band ? e.below : e.above) = c1;
            (other < band ? e.invBelow : e.invAbove) = static_cast<float>(1.0 / ds);
        }
    }
    return im.thermal;
}

double Renderer::sunlitFraction(const ThermalSurface& surface, const Vec3& towardSun) const {
    if (surface.samples_m.empty() || dot(surface.normal, towardSun) <= 0.0) return 0.0;
    int lit = 0;
    for (const Vec3& p : surface.samples_m)
        lit += impl_->occluded(p, towardSun, kInf) ? 0 : 1;
    return static_cast<double>(lit) / static_cast<double>(surface.samples_m.size());
}

void Renderer::setThermalView(const PinholeCamera& view) {
    Impl& im = *impl_;
    if (view.width <= 0 || view.height <= 0 || !(view.focalLength_m > 0.0) ||
        !(view.pitchX_m > 0.0) || !(view.pitchY_m > 0.0) || view.width > kMaxThermalViewWidth) {
        throw SetupError("render: the thermal view needs a size of 1 to " +
                         std::to_string(kMaxThermalViewWidth) +
                         " pixels across, a positive focal length and pitch");
    }
    const PinholeCamera& own = config_.camera;
    im.thermalView = view;
    const std::size_t n = static_cast<std::size_t>(view.width) * view.height;
    im.thermalSrc.assign(n, -1);
    im.thermalOwnRays = 0;
    // The view's pixel centre in this camera's image plane (the same centre of projection and
    // axes): the G-buffer pixel that holds it, if any.
    const double sx = view.pitchX_m / view.focalLength_m * own.focalLength_m / own.pitchX_m;
    const double sy = view.pitchY_m / view.focalLength_m * own.focalLength_m / own.pitchY_m;
    for (int y = 0; y < view.height; ++y) {
        const double gy = (y + 0.5 - 0.5 * view.height) * sy + 0.5 * own.height;
        for (int x = 0; x < view.width; ++x) {
            const double gx = (x + 0.5 - 0.5 * view.width) * sx + 0.5 * own.width;
            const std::size_t i = static_cast<std::size_t>(y) * view.width + x;
            if (gx >= 0.0 && gx < own.width && gy >= 0.0 && gy < own.height) {
                im.thermalSrc[i] = static_cast<std::int32_t>(static_cast<int>(gy) * own.width +
                                                             static_cast<int>(gx));
            } else {
                ++im.thermalOwnRays;
            }
        }
    }
    im.thermalPx.assign(n, Impl::ThermalPixel{});
    im.thermalGeneration = 0;
}

const PinholeCamera& Renderer::thermalView() const noexcept {
    return impl_->thermalView;
}

int Renderer::thermalOwnRays() const noexcept {
    return impl_->thermalOwnRays;
}

void Renderer::renderThermal(const ThermalFrame& frame, ImageView<float> radiance,
                             RowExecutor& exec) noexcept {
    Impl& im = *impl_;
    const int w = im.thermalView.width, h = im.thermalView.height;
    if (radiance.width() != w || radiance.height() != h || im.thermalKeys.empty()) return;
    if (im.autoPending) decideAuto(im, config_, exec);
    static const FrameSky kNoSky{};
    Ctx c{&im, &config_, &kNoSky, radiance, radiance, 1, 0u, false, false, rowStep(im.H), 1};
    updateGeometryBuffer(c, -1, exec);
    ThermalCtx tc{&im, &config_, &frame, radiance};
    if (im.thermalGeneration != im.gGeneration || im.thermalFrameTables != frame.pathTau) {
        exec.run(h, &thermalPixelRows, &tc);
        im.thermalGeneration = im.gGeneration;
        im.thermalFrameTables = frame.pathTau;
        im.primary += static_cast<std::uint64_t>(im.thermalOwnRays);
    }
    exec.run(h, &thermalRows, &tc);
}

double Renderer::thermalPixelTemperature_K(const ThermalFrame& frame, int x, int y) const noexcept {
    const Impl& im = *impl_;
    if (x < 0 || y < 0 || x >= im.thermalView.width || y >= im.thermalView.height) return 0.0;
    const Impl::ThermalPixel& p =
        im.thermalPx[static_cast<std::size_t>(y) * im.thermalView.width + x];
    if (p.cls0 < 0) return 0.0;
    const double t0 = frame.surfaceTemperature_K[p.cls0];
    if (p.cls1 < 0) return t0;
    return t0 + static_cast<double>(p.w) *
                    (static_cast<double>(frame.surfaceTemperature_K[p.cls1]) - t0);
}

int Renderer::thermalClassOfPixel(int x, int y) const noexcept {
    const Impl& im = *impl_;
    if (x < 0 || y < 0 || x >= im.thermalView.width || y >= im.thermalView.height) return -1;
    return im.thermalPx[static_cast<std::size_t>(y) * im.thermalView.width + x].cls0;
}

}  // namespace nvs::render
