// The thermal band (renderer.h, docs/thermal.md "Rendering"): the scene's faces grouped into
// surface classes for the heat balance, the Sun's shadows on them, and the per-frame band
// radiance at the aperture from the shared G-buffer.
#include <algorithm>
#include <bit>
#include <cmath>
#include <map>

#include "sim/core/simd.h"
#include "sim/render/render_impl.h"

namespace nvs::render {
namespace {

constexpr int kTilts = 5, kAzimuths = 4, kSkyViews = 4;
constexpr int kKeysPerMaterial = kTilts * kAzimuths * kSkyViews;

// The class key's bands, written once for the set-up's double normals and the per-frame
// kernel's float ones (sharedChunkKernel vectorises them: comparisons and integer arithmetic, no
// branch, no acos or atan2).
// Tilt band of a unit normal: 0 facing up (< 22.5° from the zenith) … 2 vertical … 4 down; the
// bands' edges at 22.5°, 67.5°, 112.5° and 157.5° as cosines.
template <class T>
inline int tiltBand(T nz) noexcept {
    const T cos22 = static_cast<T>(0.92387953251128674),
            cos67 = static_cast<T>(0.38268343236508978);
    return static_cast<int>(nz <= cos22) + static_cast<int>(nz <= cos67) +
           static_cast<int>(nz <= -cos67) + static_cast<int>(nz <= -cos22);
}

// Azimuth quadrant of an inclined normal (east, north components), from north through east:
// 0 N for azimuths in [−45°, 45°), 1 E in [45°, 135°), 2 S in [135°, 225°), 3 W in [225°, 315°);
// 0 for the up and down bands. The quadrants' conditions are exclusive: q = 1·E + 2·S + 3·W.
template <class T>
inline int azimuthQuadrant(T e, T no, int tilt) noexcept {
    const T zero = 0;
    const int north =
        static_cast<int>(no > zero) & static_cast<int>(-no <= e) & static_cast<int>(e < no);
    const int east =
        static_cast<int>(e > zero) & static_cast<int>(-e < no) & static_cast<int>(no <= e);
    const int south =
        static_cast<int>(no < zero) & static_cast<int>(no < e) & static_cast<int>(e <= -no);
    const int q = east + 2 * south + 3 * (1 - (north | east | south));
    return q * (static_cast<int>(tilt != 0) & static_cast<int>(tilt != kTilts - 1));
}

template <class T>
inline int skyViewBand(T svf) noexcept {
    return std::min(std::max(static_cast<int>(svf * static_cast<T>(kSkyViews)), 0), kSkyViews - 1);
}

template <class T>
inline int classKeyOf(int material, T nx, T ny, T nz, T svf) noexcept {
    const int tilt = tiltBand(nz);
    return ((material * kTilts + tilt) * kAzimuths + azimuthQuadrant(nx, ny, tilt)) * kSkyViews +
           skyViewBand(svf);
}

int classKey(int material, const Vec3& n, double svf) noexcept {
    return classKeyOf(material, n.x, n.y, n.z, svf);
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

// t[i] + f·(t[i + 1] − t[i]), the index and fraction made beforehand (no branch).
inline float lerpAt(const float* t, std::int32_t i, float f) noexcept {
    return t[i] + f * (t[i + 1] - t[i]);
}

inline float lerpTableF(const float* t, int n, float x) noexcept {
    if (x <= 0.0f) return t[0];
    if (x >= static_cast<float>(n - 1)) return t[n - 1];
    const int i = static_cast<int>(x);
    const float f = x - static_cast<float>(i);
    return t[i] + f * (t[i + 1] - t[i]);
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
    bool keep = false;  // thermalChunk keeps each pixel's data (Impl::thermalPx)
};

// The sky radiance toward a direction of zenith cosine dirZ > 0, from Impl::thermalSkyCos: the
// frame's table (uniform in zenith angle) resampled uniform in the cosine once per table
// (updateSkyCos), so that no pixel takes an acos.
constexpr int kSkyCosBins = 1024;
inline float skyAt(const Renderer::Impl& im, double dirZ) noexcept {
    return lerpTableF(im.thermalSkyCos.data(), kSkyCosBins + 1,
                      static_cast<float>(std::min(dirZ, 1.0) * kSkyCosBins));
}

void updateSkyCos(Renderer::Impl& im, const ThermalFrame& f) noexcept {
    if (im.thermalSkyTables == f.skyRadiance) return;
    for (int i = 0; i <= kSkyCosBins; ++i) {
        const double zenith_deg = std::acos(static_cast<double>(i) / kSkyCosBins) * (180.0 / kPi);
        im.thermalSkyCos[static_cast<std::size_t>(i)] =
            lerpTable(f.skyRadiance, f.skyCount, zenith_deg / 90.0 * (f.skyCount - 1));
    }
    im.thermalSkyTables = f.skyRadiance;
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
inline void pixelClasses(const Renderer::Impl::ThermalKey& k, float svf, int band,
                         std::int32_t* cls1, float* w) noexcept {
    const bool below = svf * static_cast<float>(kSkyViews) - static_cast<float>(band) < 0.5f;
    const std::int32_t c1 = below ? k.below : k.above;
    const float inv = below ? k.invBelow : k.invAbove;
    *cls1 = c1;
    *w = c1 < 0 ? 0.0f : std::clamp((svf - k.skyView) * inv, 0.0f, 1.0f);
}

// L_env = s·L_mirror + (1 − s)·(F·L_sky,diffuse + (1 − F)·L_ground): its sky part and the weight
// of L_ground (added per frame), s the specularity, F the sky-view factor; mirrorSky the sky's
// radiance toward the mirror direction when that points up (else the ground stands in).
inline void setEnvironment(Renderer::Impl::ThermalPixel& p, float s, float svf, bool mirrorUp,
                           float mirrorSky, float skyDiffuse) noexcept {
    p.envSky = (mirrorUp ? s * mirrorSky : 0.0f) + (1.0f - s) * svf * skyDiffuse;
    p.envGround = (mirrorUp ? 0.0f : s) + (1.0f - s) * (1.0f - svf);
}

// What view pixel (x, y) takes from its hit and the frame's fixed tables (Impl::ThermalPixel):
// the sky, and pixels with rays of their own (thermalChunk does the shared hits).
Renderer::Impl::ThermalPixel thermalPixel(const ThermalCtx& c, int x, int y) noexcept {
    const Renderer::Impl& im = *c.im;
    const ThermalFrame& f = *c.f;
    const std::int32_t src = im.thermalSrc[static_cast<std::size_t>(y) * im.thermalView.width + x];
    const Vec3 dir = im.pixelDir(x + 0.5, y + 0.5, im.thermalView);
    const ViewHit h = viewHit(c, dir, src);
    Renderer::Impl::ThermalPixel p;
    if (!h.hit) {  // the sky at its zenith angle; the surroundings below it
        p.envSky = dir.z > 0.0 ? skyAt(im, dir.z) : 0.0f;
        p.envGround = dir.z > 0.0 ? 0.0f : 1.0f;
        return p;
    }
    const Vec3 d = h.p - im.camPos;
    const double r = std::max(norm(d), 1e-3);
    const Vec3 view = d * (-1.0 / r);
    const double k = (std::log(r) - f.lnRange0) / f.lnRangeStep;
    p.tau = lerpTable(f.pathTau, f.rangeCount, k);
    p.path = lerpTable(f.pathRadiance, f.rangeCount, k);
    const Renderer::Impl::ThermalKey& key =
        im.thermalKeys[static_cast<std::size_t>(classKey(h.material, h.n, h.svf))];
    p.cls0 = key.cls;
    if (p.cls0 < 0) {  // a material without a class: the air's temperature, black
        p.envGround = 1.0f;
        return p;
    }
    const float svf = static_cast<float>(h.svf);
    pixelClasses(key, svf, skyViewBand(h.svf), &p.cls1, &p.w);
    const double cosT = std::clamp(dot(h.n, view), 0.0, 1.0);
    const float* eps = f.emissivity + static_cast<std::size_t>(p.cls0) * kThermalCosBins;
    p.eps = lerpTable(eps, kThermalCosBins, cosT * (kThermalCosBins - 1));
    const float s = key.specularity;
    const double mirrorZ = h.n.z * (2.0 * cosT) - view.z;
    const bool mirrorUp = mirrorZ > 0.0;
    setEnvironment(p, s, svf, mirrorUp, mirrorUp && s > 0.0f ? skyAt(im, mirrorZ) : 0.0f,
                   static_cast<float>(f.skyDiffuse));
    return p;
}

// The per-pixel part of a shared hit that needs no table, for a chunk of pixels: positions
// relative to the camera p, normals n, sky-view factors and materials in; cos θ toward the
// camera, the mirror direction's z, the table positions of ln r, cos θ and the mirror's zenith
// cosine, and the class key out. Plain
// loops over arrays, which each version of NVS_SIMD_CLONES vectorises (thermal.cpp is built with
// -ffp-contract=off: every version does the same IEEE operations, so the same bits).
//
// ln r without libm: r = 2^e·m with m in [√½, √2), ln m = 2·atanh(s), s = (m − 1)/(m + 1),
// |s| ≤ 0.172, the series to s⁹ (error below 4e-10, far below what the tables' 0.1 steps in ln r
// need); libm's log is a call per pixel that no version vectorises.
struct SharedChunk {
    static constexpr int kN = 256;
    float px[kN], py[kN], pz[kN], nx[kN], ny[kN], nz[kN], svf[kN];
    std::int32_t material[kN];
    float cosT[kN], mirrorZ[kN];
    // Table positions as index and fraction (lerpAt): ln r in τ and L_path, cos θ in ε(θ).
    std::int32_t kIdx[kN], eIdx[kN], sIdx[kN];
    float kFrac[kN], eFrac[kN], sFrac[kN];  // s: the mirror's zenith cosine in thermalSkyCos
    std::int32_t key[kN];
    bool own[kN];  // the sky or a ray of its own: thermalPixel
};

NVS_SIMD_CLONES void sharedChunkKernel(SharedChunk& c, int n, float lnRange0, float perLnStep,
                                       int rangeCount) noexcept {
    // The last index whose next entry exists: positions at or past the table's end read its
    // last interval at fraction 1.
    const float kMax = static_cast<float>(rangeCount - 1) * 0.99999988f;
    constexpr float kLn2 = 0.693147181f;
    for (int j = 0; j < n; ++j) {
        const float r0 = std::sqrt(c.px[j] * c.px[j] + c.py[j] * c.py[j] + c.pz[j] * c.pz[j]);
        const float r = r0 > 1e-3f ? r0 : 1e-3f;
        const float inv = 1.0f / r;
        const float vx = -c.px[j] * inv, vy = -c.py[j] * inv, vz = -c.pz[j] * inv;
        const float d0 = c.nx[j] * vx + c.ny[j] * vy + c.nz[j] * vz;
        const float d1 = d0 > 0.0f ? d0 : 0.0f;
        const float cosT = d1 < 1.0f ? d1 : 1.0f;
        c.cosT[j] = cosT;
        c.mirrorZ[j] = c.nz[j] * (2.0f * cosT) - vz;
        // ln r
        const std::uint32_t bits = std::bit_cast<std::uint32_t>(r);
        int e = static_cast<int>(bits >> 23) - 127;
        float m = std::bit_cast<float>((bits & 0x007fffffu) | 0x3f800000u);
        const int high = static_cast<int>(m > 1.41421356f);
        m *= 1.0f - 0.5f * static_cast<float>(high);
        e += high;
        const float sm = (m - 1.0f) / (m + 1.0f), s2 = sm * sm;
        const float lnM =
            2.0f * sm *
            (1.0f +
             s2 * (1.0f / 3.0f + s2 * (1.0f / 5.0f + s2 * (1.0f / 7.0f + s2 * (1.0f / 9.0f)))));
        const float k = (static_cast<float>(e) * kLn2 + lnM - lnRange0) * perLnStep;
        const float kc = k > 0.0f ? (k < kMax ? k : kMax) : 0.0f;
        c.kIdx[j] = static_cast<std::int32_t>(kc);
        c.kFrac[j] = kc - static_cast<float>(c.kIdx[j]);
        const float ec = cosT * static_cast<float>(kThermalCosBins - 1) * 0.99999988f;
        c.eIdx[j] = static_cast<std::int32_t>(ec);
        c.eFrac[j] = ec - static_cast<float>(c.eIdx[j]);
        const float mz = c.mirrorZ[j] > 0.0f ? (c.mirrorZ[j] < 1.0f ? c.mirrorZ[j] : 1.0f) : 0.0f;
        const float sc = mz * static_cast<float>(kSkyCosBins) * 0.99999988f;
        c.sIdx[j] = static_cast<std::int32_t>(sc);
        c.sFrac[j] = sc - static_cast<float>(c.sIdx[j]);
        c.key[j] = classKeyOf(c.material[j], c.nx[j], c.ny[j], c.nz[j], c.svf[j]);
    }
}

// The band radiance at the aperture of a pixel: L = τ·(ε·B + (1 − ε)·(L_sky + a·L_ground)) + L_path
// (the cached and the fused path both end here). B is blended between the pixel's two classes'
// B(T) (classB, this frame's, per class) by the same weight as their temperatures would be: the
// classes of neighbouring sky-view bands differ by a kelvin or less, over which B(T) is straight
// to 1e-4 of the difference (B'' ΔT²/8).
inline float pixelRadiance(const Renderer::Impl::ThermalPixel& p, const float* classB,
                           float air) noexcept {
    float b = 0.0f;
    if (p.cls0 >= 0) {
        // Without a second class the weight is 0 and the class itself stands in (no branch).
        const float ba = classB[p.cls0];
        const float bb = classB[p.cls1 >= 0 ? p.cls1 : p.cls0];
        b = ba + p.w * (bb - ba);
    }
    const float env = p.envSky + p.envGround * air;
    return p.tau * (p.eps * b + (1.0f - p.eps) * env) + p.path;
}

// Pixels x0 … x0+n−1 of view row y whose hits are shared: the G-buffer's, through the kernel,
// then the tables. Others (the sky, own rays) through thermalPixel.
// Writes each pixel's radiance to the output and, with c.keep, what it took to Impl::thermalPx.
void thermalChunk(const ThermalCtx& c, int y, int x0, int n, SharedChunk& ch) noexcept {
    const Renderer::Impl& im = *c.im;
    const ThermalFrame& f = *c.f;
    const int w = im.thermalView.width;
    const std::int32_t* src = &im.thermalSrc[static_cast<std::size_t>(y) * w + x0];
    const float cx = static_cast<float>(im.camPos.x), cy = static_cast<float>(im.camPos.y),
                cz = static_cast<float>(im.camPos.z);
    for (int j = 0; j < n; ++j) {
        const std::size_t i = static_cast<std::size_t>(src[j] < 0 ? 0 : src[j]);
        const bool shared = src[j] >= 0 && im.gMat[i] != kMiss;
        ch.own[j] = !shared;
        ch.px[j] = shared ? im.gPos[3 * i] - cx : 0.0f;
        ch.py[j] = shared ? im.gPos[3 * i + 1] - cy : 0.0f;
        ch.pz[j] = shared ? im.gPos[3 * i + 2] - cz : -1.0f;
        ch.nx[j] = shared ? im.gNrm[3 * i] : 0.0f;
        ch.ny[j] = shared ? im.gNrm[3 * i + 1] : 0.0f;
        ch.nz[j] = shared ? im.gNrm[3 * i + 2] : 1.0f;
        ch.svf[j] = shared ? im.gSvf[i] : 0.0f;
        ch.material[j] = shared ? im.gMat[i] : 0;
    }
    sharedChunkKernel(ch, n, static_cast<float>(f.lnRange0),
                      static_cast<float>(1.0 / f.lnRangeStep), f.rangeCount);
    Renderer::Impl::ThermalPixel* kept = &c.im->thermalPx[static_cast<std::size_t>(y) * w + x0];
    float* row = c.out.row(y) + x0;
    const float air = static_cast<float>(f.groundRadiance);
    const float* classB = im.thermalClassB.data();
    const auto put = [&](int j, const Renderer::Impl::ThermalPixel& p) {
        row[j] = pixelRadiance(p, classB, air);
        if (c.keep) kept[j] = p;
    };
    for (int j = 0; j < n; ++j) {
        if (ch.own[j]) {
            put(j, thermalPixel(c, x0 + j, y));
            continue;
        }
        Renderer::Impl::ThermalPixel p;
        p.tau = lerpAt(f.pathTau, ch.kIdx[j], ch.kFrac[j]);
        p.path = lerpAt(f.pathRadiance, ch.kIdx[j], ch.kFrac[j]);
        const Renderer::Impl::ThermalKey& key = im.thermalKeys[static_cast<std::size_t>(ch.key[j])];
        p.cls0 = key.cls;
        if (p.cls0 < 0) {  // a material without a class: the air's temperature, black
            p.envGround = 1.0f;
            put(j, p);
            continue;
        }
        const float svf = ch.svf[j];
        pixelClasses(key, svf, ch.key[j] % kSkyViews, &p.cls1, &p.w);
        const float* eps = f.emissivity + static_cast<std::size_t>(p.cls0) * kThermalCosBins;
        p.eps = lerpAt(eps, ch.eIdx[j], ch.eFrac[j]);
        const float s = key.specularity;
        const bool mirrorUp = ch.mirrorZ[j] > 0.0f;
        setEnvironment(
            p, s, svf, mirrorUp,
            mirrorUp && s > 0.0f ? lerpAt(im.thermalSkyCos.data(), ch.sIdx[j], ch.sFrac[j]) : 0.0f,
            static_cast<float>(f.skyDiffuse));
        put(j, p);
    }
}

void thermalPixelRows(void* arg, int y0, int y1) noexcept {
    const ThermalCtx& c = *static_cast<const ThermalCtx*>(arg);
    const int w = c.im->thermalView.width;
    SharedChunk chunk;
    for (int y = y0; y < y1; ++y) {
        for (int x0 = 0; x0 < w; x0 += SharedChunk::kN)
            thermalChunk(c, y, x0, std::min(SharedChunk::kN, w - x0), chunk);
    }
}

// Per frame with the pixels' data kept (the same hits as the frame before): the radiance alone.
void thermalRows(void* arg, int y0, int y1) noexcept {
    const ThermalCtx& c = *static_cast<const ThermalCtx*>(arg);
    const Renderer::Impl& im = *c.im;
    const ThermalFrame& f = *c.f;
    const float air = static_cast<float>(f.groundRadiance);
    const float* classB = im.thermalClassB.data();
    for (int y = y0; y < y1; ++y) {
        float* row = c.out.row(y);
        const int w = im.thermalView.width;
        const Renderer::Impl::ThermalPixel* px = &im.thermalPx[static_cast<std::size_t>(y) * w];
        for (int x = 0; x < w; ++x)
            row[x] = pixelRadiance(px[x], classB, air);
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
    im.thermalSkyCos.assign(kSkyCosBins + 1, 0.0f);
    im.thermalClassB.assign(im.thermal.size(), 0.0f);
    im.thermalSkyTables = nullptr;
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
        !(view.pitchX_m > 0.0) || !(view.pitchY_m > 0.0)) {
        throw SetupError("render: the thermal view needs a positive size, focal length and pitch");
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
    im.thermalSeenGeneration = 0;
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
    updateSkyCos(im, frame);
    // Each class's B(T) at this frame's temperatures.
    const float t0 = static_cast<float>(frame.blackbodyT0_K);
    const float perK = static_cast<float>(1.0 / frame.blackbodyStep_K);
    for (std::size_t k = 0; k < im.thermalClassB.size(); ++k)
        im.thermalClassB[k] = lerpTableF(frame.blackbody, frame.blackbodyCount,
                                         (frame.surfaceTemperature_K[k] - t0) * perK);
    ThermalCtx tc{&im, &config_, &frame, radiance};
    if (im.thermalGeneration == im.gGeneration && im.thermalFrameTables == frame.pathTau) {
        exec.run(h, &thermalRows, &tc);  // the hits as before: each pixel's data kept
        return;
    }
    // New hits: each pixel from its hit, straight to the radiance. The pixels' data are kept
    // only when the hits stood since the frame before (a held camera), not for a moving one,
    // whose kept data no frame would use (writing them cost a moving frame a third of its time).
    tc.keep = im.thermalSeenGeneration == im.gGeneration && im.thermalSeenTables == frame.pathTau;
    exec.run(h, &thermalPixelRows, &tc);
    im.primary += static_cast<std::uint64_t>(im.thermalOwnRays);
    im.thermalSeenGeneration = im.gGeneration;
    im.thermalSeenTables = frame.pathTau;
    if (tc.keep) {
        im.thermalGeneration = im.gGeneration;
        im.thermalFrameTables = frame.pathTau;
    }
}

double Renderer::thermalPixelTemperature_K(const ThermalFrame& frame, int x, int y) const noexcept {
    const Impl& im = *impl_;
    if (x < 0 || y < 0 || x >= im.thermalView.width || y >= im.thermalView.height ||
        im.thermalKeys.empty()) {
        return 0.0;
    }
    const ThermalCtx tc{impl_.get(), &config_, &frame, ImageView<float>{}};
    const Impl::ThermalPixel p = thermalPixel(tc, x, y);
    if (p.cls0 < 0) return 0.0;
    const double t0 = frame.surfaceTemperature_K[p.cls0];
    if (p.cls1 < 0) return t0;
    return t0 + static_cast<double>(p.w) *
                    (static_cast<double>(frame.surfaceTemperature_K[p.cls1]) - t0);
}

int Renderer::thermalClassOfPixel(int x, int y) const noexcept {
    const Impl& im = *impl_;
    if (x < 0 || y < 0 || x >= im.thermalView.width || y >= im.thermalView.height ||
        im.thermalKeys.empty()) {
        return -1;
    }
    const ThermalCtx tc{impl_.get(), &config_, nullptr, ImageView<float>{}};
    const Vec3 dir = im.pixelDir(x + 0.5, y + 0.5, im.thermalView);
    const ViewHit h =
        viewHit(tc, dir, im.thermalSrc[static_cast<std::size_t>(y) * im.thermalView.width + x]);
    if (!h.hit) return -1;
    return im.thermalKeys[static_cast<std::size_t>(classKey(h.material, h.n, h.svf))].cls;
}

}  // namespace nvs::render
