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

// Tilt band of a unit normal: 0 facing up (< 22.5° from the zenith) … 2 vertical … 4 down.
int tiltBand(double nz) noexcept {
    const double tilt_deg = std::acos(std::clamp(nz, -1.0, 1.0)) * (180.0 / kPi);
    return std::min(kTilts - 1, static_cast<int>((tilt_deg + 22.5) / 45.0));
}

// Azimuth quadrant (N, E, S, W) of an inclined normal; 0 for the up and down bands.
int azimuthQuadrant(const Vec3& n, int tilt) noexcept {
    if (tilt == 0 || tilt == kTilts - 1) return 0;
    double az_deg = std::atan2(n.x, n.y) * (180.0 / kPi);  // x east, y north
    if (az_deg < 0.0) az_deg += 360.0;
    return static_cast<int>(std::fmod(az_deg + 45.0, 360.0) / 90.0) % kAzimuths;
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

// The classes a pixel's temperature comes from: its class, and the class of the neighbouring
// sky-view band toward its own sky-view factor with the weight between them, linear in the
// classes' mean sky-view factors (a surface whose sky view changes across it has no steps at
// the bands' edges).
void pixelClasses(const Renderer::Impl& im, std::size_t i, int cls, std::int32_t* cls1,
                  float* w) noexcept {
    *cls1 = -1;
    *w = 0.0f;
    const double svf = im.gSvf[i];
    const int band = skyViewBand(svf);
    const int other = svf * kSkyViews - band < 0.5 ? band - 1 : band + 1;
    if (other < 0 || other >= kSkyViews) return;
    const int key = classKey(im.gMat[i], g3(im.gNrm, i), svf) - band + other;
    const int c1 = im.thermalOfKey[static_cast<std::size_t>(key)];
    if (c1 < 0 || c1 == cls) return;
    const double s0 = im.thermal[static_cast<std::size_t>(cls)].skyView;
    const double s1 = im.thermal[static_cast<std::size_t>(c1)].skyView;
    if (std::fabs(s1 - s0) < 1e-3) return;
    *cls1 = c1;
    *w = static_cast<float>(std::clamp((svf - s0) / (s1 - s0), 0.0, 1.0));
}

// What pixel i takes from the G-buffer and the frame's fixed tables (Impl::ThermalPixel).
Renderer::Impl::ThermalPixel thermalPixel(const ThermalCtx& c, int x, int y) noexcept {
    const Renderer::Impl& im = *c.im;
    const ThermalFrame& f = *c.f;
    const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
    Renderer::Impl::ThermalPixel p;
    if (im.gMat[i] == kMiss) {  // the sky at its zenith angle; the surroundings below it
        const double dz = im.pixelDir(x + 0.5, y + 0.5, c.cfg->camera).z;
        p.envSky = dz > 0.0 ? skyAt(f, dz) : 0.0f;
        p.envGround = dz > 0.0 ? 0.0f : 1.0f;
        return p;
    }
    const Vec3 d = g3(im.gPos, i) - im.camPos;
    const double r = std::max(norm(d), 1e-3);
    const Vec3 view = d * (-1.0 / r);
    const double k = (std::log(r) - f.lnRange0) / f.lnRangeStep;
    p.tau = lerpTable(f.pathTau, f.rangeCount, k);
    p.path = lerpTable(f.pathRadiance, f.rangeCount, k);
    const Vec3 n = g3(im.gNrm, i);
    p.cls0 = im.thermalOfKey[static_cast<std::size_t>(classKey(im.gMat[i], n, im.gSvf[i]))];
    if (p.cls0 < 0) {  // a material without a class: the air's temperature, black
        p.envGround = 1.0f;
        return p;
    }
    pixelClasses(im, i, p.cls0, &p.cls1, &p.w);
    const double cosT = std::clamp(dot(n, view), 0.0, 1.0);
    const float* eps = f.emissivity + static_cast<std::size_t>(p.cls0) * kThermalCosBins;
    p.eps = lerpTable(eps, kThermalCosBins, cosT * (kThermalCosBins - 1));
    // L_env = s·L_mirror + (1 − s)·(F·L_sky,diffuse + (1 − F)·B(T_air)), its sky and air parts.
    const double svf = im.gSvf[i];
    const double s = im.materials[im.gMat[i]].specularity;
    const Vec3 mirror = n * (2.0 * cosT) - view;
    const bool mirrorUp = mirror.z > 0.0;
    p.envSky = static_cast<float>((mirrorUp ? s * static_cast<double>(skyAt(f, mirror.z)) : 0.0) +
                                  (1.0 - s) * svf * f.skyDiffuse);
    p.envGround = static_cast<float>((mirrorUp ? 0.0 : s) + (1.0 - s) * (1.0 - svf));
    return p;
}

void thermalPixelRows(void* arg, int y0, int y1) noexcept {
    const ThermalCtx& c = *static_cast<const ThermalCtx*>(arg);
    for (int y = y0; y < y1; ++y) {
        for (int x = 0; x < c.im->W; ++x)
            c.im->thermalPx[static_cast<std::size_t>(y) * c.im->W + x] = thermalPixel(c, x, y);
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
        const Renderer::Impl::ThermalPixel* px = &im.thermalPx[static_cast<std::size_t>(y) * im.W];
        for (int x = 0; x < im.W; ++x) {
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
    im.thermalPx.assign(static_cast<std::size_t>(im.W) * im.H, Impl::ThermalPixel{});
    im.thermalGeneration = 0;
    const std::size_t keys = im.materials.size() * kKeysPerMaterial;
    im.thermalOfKey.assign(keys, -1);
    for (std::size_t k = 0; k < keys; ++k) {
        double best = 1e30;
        for (std::size_t s = 0; s < im.thermal.size(); ++s) {
            const int key = im.thermal[s].key;
            if (key / kKeysPerMaterial != static_cast<int>(k) / kKeysPerMaterial) continue;
            const double dist = keyDistance(key, static_cast<int>(k));
            if (dist < best) best = dist, im.thermalOfKey[k] = static_cast<std::int32_t>(s);
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

void Renderer::renderThermal(const ThermalFrame& frame, ImageView<float> radiance,
                             RowExecutor& exec) noexcept {
    Impl& im = *impl_;
    if (radiance.width() != im.W || radiance.height() != im.H || im.thermalOfKey.empty()) return;
    if (im.autoPending) decideAuto(im, config_, exec);
    static const FrameSky kNoSky{};
    Ctx c{&im, &config_, &kNoSky, radiance, radiance, 1, 0u, false, false, rowStep(im.H), 1};
    updateGeometryBuffer(c, -1, exec);
    ThermalCtx tc{&im, &config_, &frame, radiance};
    if (im.thermalGeneration != im.gGeneration || im.thermalFrameTables != frame.pathTau) {
        exec.run(im.H, &thermalPixelRows, &tc);
        im.thermalGeneration = im.gGeneration;
        im.thermalFrameTables = frame.pathTau;
    }
    exec.run(im.H, &thermalRows, &tc);
}

double Renderer::thermalPixelTemperature_K(const ThermalFrame& frame, int x, int y) const noexcept {
    const int cls = thermalClassOfPixel(x, y);
    if (cls < 0) return 0.0;
    std::int32_t cls1 = -1;
    float w = 0.0f;
    pixelClasses(*impl_, static_cast<std::size_t>(y) * impl_->W + x, cls, &cls1, &w);
    const double t0 = frame.surfaceTemperature_K[cls];
    if (cls1 < 0) return t0;
    return t0 +
           static_cast<double>(w) * (static_cast<double>(frame.surfaceTemperature_K[cls1]) - t0);
}

int Renderer::thermalClassOfPixel(int x, int y) const noexcept {
    const Impl& im = *impl_;
    const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
    if (im.gMat[i] == kMiss || im.thermalOfKey.empty()) return -1;
    return im
        .thermalOfKey[static_cast<std::size_t>(classKey(im.gMat[i], g3(im.gNrm, i), im.gSvf[i]))];
}

}  // namespace nvs::render
