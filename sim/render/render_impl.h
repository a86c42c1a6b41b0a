#pragma once
// The renderer's inside (sim/render/renderer.h is its outside), shared by the files that hold
// its jobs: embree_scene.cpp (the Embree scene and the objects' placement), light_setup.cpp
// (source and lamp coefficients, sky-view factors, the per-frame coefficients and sky in view),
// primary.cpp (the G-buffer: Embree's or OpenGL's primary visibility, what moving objects
// invalidate), shading.cpp (lamp and Moon factors, static data, full-rate shading), coarse.cpp
// (coarse tiles: nodes, upsampling weights) and point_sources.cpp (lamps and stars in view).
// Only those files include it.

#include <embree3/rtcore.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdint>
#include <limits>
#include <memory>
#include <numeric>
#include <string>
#include <vector>

#include "sim/core/units.h"
#include "sim/render/gl_visibility.h"
#include "sim/render/renderer.h"

namespace nvs::render::detail {

constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::uint16_t kMiss = 0xFFFF;
constexpr std::uint16_t kNotSpecular = 0xFFFE;
constexpr int kMaxLampsStatic = 32;
// The sky radiance grid (sim/sky/atmosphere_table.h: view zenith 0–90° and Δφ 0–180°).
constexpr int kSkyZ = msg::kSkyViewZeniths;
constexpr int kSkyA = msg::kSkyAzimuths;
constexpr double kSkyStepZ_deg = 90.0 / (kSkyZ - 1);
constexpr double kSkyStepA_deg = 180.0 / (kSkyA - 1);

struct Vec3f {
    float x, y, z;
};

inline Vec3 toV(const Vec3f& a) {
    return {a.x, a.y, a.z};
}

// Three floats of a G-buffer at pixel i.
inline Vec3 g3(const std::vector<float>& a, std::size_t i) {
    return {static_cast<double>(a[3 * i]), static_cast<double>(a[3 * i + 1]),
            static_cast<double>(a[3 * i + 2])};
}

// Ray-offset along the normal that clears float precision at scene scale (tens of metres).
constexpr double kEps_m = 2e-4;

// Hammersley point i of n on the unit square (deterministic stratified directions).
inline void hammersley(int i, int n, double* u, double* v) {
    std::uint32_t b = static_cast<std::uint32_t>(i);
    b = (b << 16u) | (b >> 16u);
    b = ((b & 0x55555555u) << 1u) | ((b & 0xAAAAAAAAu) >> 1u);
    b = ((b & 0x33333333u) << 2u) | ((b & 0xCCCCCCCCu) >> 2u);
    b = ((b & 0x0F0F0F0Fu) << 4u) | ((b & 0xF0F0F0F0u) >> 4u);
    b = ((b & 0x00FF00FFu) << 8u) | ((b & 0xFF00FF00u) >> 8u);
    *u = (i + 0.5) / n;
    *v = static_cast<double>(b) * 2.3283064365386963e-10;
}

inline void basisAround(const Vec3& n, Vec3* t, Vec3* b) {
    const Vec3 a = std::abs(n.x) > 0.9 ? Vec3{0, 1, 0} : Vec3{1, 0, 0};
    *t = normalized(cross(a, n));
    *b = cross(n, *t);
}

inline void setRay(RTCRay& r, const Vec3& o, const Vec3& d, float tnear, float tfar) {
    r.org_x = static_cast<float>(o.x);
    r.org_y = static_cast<float>(o.y);
    r.org_z = static_cast<float>(o.z);
    r.dir_x = static_cast<float>(d.x);
    r.dir_y = static_cast<float>(d.y);
    r.dir_z = static_cast<float>(d.z);
    r.tnear = tnear;
    r.tfar = tfar;
    r.time = 0.0f;
    r.mask = 0xFFFFFFFFu;
    r.id = 0;
    r.flags = 0;
}

struct LampData {
    Vec3 position;
    Vec3 axis;
    double cosCutoff = -1.0;
    bool aperture = false;
    std::vector<Vec3> samples;  // aperture sample points
    double sampleArea_m2 = 0.0;
    std::vector<double> coef;      // [m][b] ∫ S ρ w / π (S = I, or L_glass with an aperture)
    BandValues emitted{};          // ∫ S w: intensity (point) or glass radiance (aperture)
    BandValues glassRadiance{};    // ∫ L_glass w (what the camera sees)
    double radius_m = 0.0;         // visible emitter radius (bulb or aperture)
    double farDistance2_m2 = 0.0;  // (30 aperture radii)²: beyond, the disk is one sample
    // A lamp riding on an object (scene::Lamp::attachObject ≥ 0): its pose in the object's
    // frame, placed at each setTime (placeAttachedLamps).
    int attach = -1;
    scene::Lamp local;
};

struct ObjectData {
    RTCGeometry geom = nullptr;
    unsigned geomId = 0;
    const scene::Object* obj = nullptr;
    std::vector<std::uint16_t> material;  // per triangle
    std::vector<float> svf;               // per triangle: 3 corners × (front, back)
    Vec3f* vbuf = nullptr;                // Embree's vertex buffer (world)
    bool placed = false;
};

}  // namespace nvs::render::detail

namespace nvs::render {

using namespace detail;  // the renderer's files only

struct Renderer::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<ObjectData> objects;
    std::vector<scene::Material> materials;
    std::vector<LampData> lamps;
    double time_s = 0.0;  // the scene's time (setTime)
    // Camera
    Vec3 camPos, camFwd, camRight, camUp;
    // G-buffer
    int W = 0, H = 0;
    std::vector<float> gPos;  // xyz
    std::vector<float> gNrm;  // xyz (facing the camera)
    std::vector<float> gSvf;
    std::vector<std::uint16_t> gMat;
    std::vector<std::int16_t> gObj;
    // Thermal classes (thermal.cpp): the classes and, per class key, the class that stands
    // for it (the nearest present class where a key has no face of its own).
    std::vector<ThermalSurface> thermal;
    // Per class key: the class that stands for it, the classes of the sky-view bands below and
    // above it (−1: none, or no sky-view difference) with 1/(their mean sky view − its own), its
    // own mean sky view, and the material's specularity (what each pixel would otherwise look up).
    struct ThermalKey {
        std::int32_t cls = -1, below = -1, above = -1;
        float skyView = 0.0f, invBelow = 0.0f, invAbove = 0.0f, specularity = 0.0f;
    };
    std::vector<ThermalKey> thermalKeys;
    // Per pixel, what the thermal band takes from the G-buffer alone (thermal.cpp), valid for
    // G-buffer generation thermalGeneration: the two classes and the weight between them, the
    // emissivity toward the camera, the environment's sky part and its air-radiance weight,
    // τ(r) and L_path(r) (the sky: class −1, its radiance in path).
    struct ThermalPixel {
        std::int32_t cls0 = -1, cls1 = -1;
        float w = 0.0f, eps = 0.0f, envSky = 0.0f, envGround = 0.0f, tau = 1.0f, path = 0.0f;
    };
    std::vector<ThermalPixel> thermalPx;  // per pixel of the thermal view
    // The thermal view (Renderer::setThermalView): its pinhole, and per pixel the G-buffer
    // pixel whose primary hit it takes (−1: outside this camera's image, a ray of its own).
    PinholeCamera thermalView;
    std::vector<std::int32_t> thermalSrc;
    int thermalOwnRays = 0;  // pixels with a ray of their own
    std::uint64_t thermalGeneration = 0;
    const void* thermalFrameTables = nullptr;  // the ThermalFrame tables they came from
    // The generation and tables of the last thermal frame (kept or not): a second frame on the
    // same hits keeps the pixels' data.
    // The frame's sky radiance resampled uniform in the zenith cosine (thermal.cpp, skyAt), and
    // the table it came from.
    std::vector<float> thermalSkyCos;
    std::vector<float> thermalClassB;  // per class, this frame's B(T) (renderThermal)
    const void* thermalSkyTables = nullptr;
    std::uint64_t thermalSeenGeneration = 0;
    const void* thermalSeenTables = nullptr;
    // Static lighting data per pixel: everything about a pixel's light that depends only on the
    // geometry, the camera and the lamps' placement, kept as long as the G-buffer is (a fixed
    // camera over a static scene computes it once). Built lazily for the pixels that are shaded
    // at full rate or are coarse nodes; staticNeed says which lamps (bits 0..31) and whether the
    // specular bounce (kSpecBit) it covers.
    std::vector<std::uint8_t> sValid;
    std::vector<float> sLamp;          // [i nl + l] lamp factors at the primary hit
    std::vector<std::uint16_t> sqMat;  // specular hit's material; kMiss: sky; kNotSpecular
    std::vector<float> sqPos, sqNrm;   // specular hit (on a miss: direction; zenith, azimuth)
    std::vector<float> sqSvf;          // specular hit's sky-view factor
    std::vector<float> sqLamp;         // [i nl + l] lamp factors at the specular hit
    std::uint64_t staticNeed = 0;
    // Coarse lighting nodes: radiance without the sky term [node kBands + b]; upsampling
    // weights per pixel (4 taps: (j, k), (j, k+1), (j+1, k), (j+1, k+1)) and kind (kUpMiss,
    // kUpInterp, kUpFull), built for coarse factor uFactor (0: not built).
    int nodeW = 0, nodeH = 0;
    std::vector<float> nodeRad;
    std::vector<float> uW;
    std::vector<std::uint8_t> uKind;
    int uFactor = 0;
    // Per-frame coefficients [m kBands + b] (kLamp: [(l nm + m) kBands + b]): radiance per unit
    // factor, with the frame's source levels, the material's (1 − s) and the term switches.
    std::vector<float> kMoon, kSky, kSpec, kLamp;
    // The lamps this frame's sums take (on, with the lamp term): every other one's kLamp is 0.
    int activeLamp[kMaxLampsStatic] = {};
    int activeLamps = 0;
    // Per-frame sky radiance in view [b][view zenith][Δφ] on the atmosphere table's own grid
    // (night sky + E_toa × lunar sky radiance at this frame's Moon zenith).
    std::vector<float> skyTab;
    std::atomic<std::uint64_t> primary{0}, shadow{0}, secondary{0};
    // Rows of the G-buffer that match the current camera and geometry: bit 0 the even rows,
    // bit 1 the odd ones (a field renders only its own rows, Renderer::render).
    unsigned gValidRows = 0;
    // Counts every change of the G-buffer (castRows, redoMovedObjects): per-pixel data derived
    // from it (the thermal band's) is rebuilt when this moved.
    std::uint64_t gGeneration = 1;
    // Objects that moved since the last render while the camera stayed: each leaves a box (the
    // union of its bounds before and after) through which every ray whose result may have
    // changed passes. The next render redoes only the primary rays of the pixels the boxes
    // cover on screen, and the static data of the pixels whose lamp or mirror rays cross a box;
    // more boxes than kMaxDirty rebuild the whole G-buffer.
    static constexpr int kMaxDirty = 8;
    Vec3 dirtyLo[kMaxDirty], dirtyHi[kMaxDirty];
    int nDirty = 0;
    // OpenGL primary visibility (gl_visibility.h; RenderConfig::primaryVisibility): the pass,
    // whether it makes the G-buffer, which objects' vertices changed since they were uploaded,
    // why there is no pass, the auto choice's timings, passes that failed (Embree redid them).
    std::unique_ptr<GlVisibility> gl;
    bool useGl = false, autoPending = false;
    std::vector<std::uint8_t> glStale;
    std::string glReason;
    double autoEmbree_ms = -1.0, autoGl_ms = -1.0;
    std::uint64_t glFailures = 0;

    ~Impl() {
        if (scene) rtcReleaseScene(scene);
        if (device) rtcReleaseDevice(device);
    }

    bool occluded(const Vec3& o, const Vec3& d, float tfar) const noexcept {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        RTCRay r;
        setRay(r, o, d, 0.0f, tfar);
        rtcOccluded1(scene, &ctx, &r);
        return r.tfar < 0.0f;
    }

    bool intersect(const Vec3& o, const Vec3& d, RTCRayHit* rh) const noexcept {
        RTCIntersectContext ctx;
        rtcInitIntersectContext(&ctx);
        setRay(rh->ray, o, d, 0.0f, kInf);
        rh->hit.geomID = RTC_INVALID_GEOMETRY_ID;
        rh->hit.instID[0] = RTC_INVALID_GEOMETRY_ID;
        rtcIntersect1(scene, &ctx, rh);
        return rh->hit.geomID != RTC_INVALID_GEOMETRY_ID;
    }

    Vec3 pixelDir(double px, double py, const PinholeCamera& c) const noexcept {
        const double u = (px - 0.5 * c.width) * c.pitchX_m;
        const double v = (py - 0.5 * c.height) * c.pitchY_m;
        return normalized(camFwd * c.focalLength_m + camRight * u - camUp * v);
    }

    // Pinhole projection of a scene point to pixel coordinates (the inverse of pixelDir: pixel
    // x grows along camRight, y along −camUp). False when the point is not in front: not more
    // than `minDepth_m` along the optical axis.
    bool project(const Vec3& q, const PinholeCamera& c, double* u, double* v,
                 double minDepth_m = 1e-6) const noexcept {
        const Vec3 d = q - camPos;
        const double zf = dot(d, camFwd);
        if (!(zf > minDepth_m)) return false;
        *u = dot(d, camRight) / zf * c.focalLength_m / c.pitchX_m + 0.5 * c.width;
        *v = -dot(d, camUp) / zf * c.focalLength_m / c.pitchY_m + 0.5 * c.height;
        return true;
    }
};

}  // namespace nvs::render

namespace nvs::render::detail {

constexpr int kPacket = 16;
constexpr int kTileW = 16, kTileH = 1;  // a packet's pixels
constexpr std::uint64_t kSpecBit = std::uint64_t{1} << kMaxLampsStatic;
constexpr std::uint8_t kUpMiss = 0, kUpInterp = 1, kUpFull = 2;

struct Ctx {
    Renderer::Impl* im;
    const RenderConfig* cfg;
    const FrameSky* sky;
    ImageView<float> pe, bw;
    int coarse;
    unsigned terms;
    bool moonOn;                             // Moon up and its term asked for
    bool buildWeights;                       // the upsampling pass (re)builds its weights
    int rowStepImage = 1, rowStepNodes = 1;  // rowStep(H), rowStep(nodeH)
    // The primary pass covers rows rowLo + rowStride·i, 0 ≤ i < rowCount (spread by
    // rowStepRect) and columns [colLo, colHi); weights are rebuilt on rows [weightsLo,
    // weightsHi).
    int rowLo = 0, rowCount = 0, rowStride = 1, rowStepRect = 1, colLo = 0, colHi = 0;
    // The shading passes cover the rows of parity rowParity (shadeCount of them, spread by
    // rowStepShade), or every row when rowParity < 0.
    int rowParity = -1, shadeCount = 0, rowStepShade = 1;
    int weightsLo = 0, weightsHi = 0;
    // Sky in view: the Moon's azimuth, its disk (cos of its angular radius, radiance E☾/Ω☾).
    float moonAz_rad = 0.0f;
    float moonDir[3] = {0.0f, 0.0f, 1.0f};
    float cosMoonRadius = 2.0f;  // > 1: no disk
    float moonDisk[kBands] = {0.0f, 0.0f};
};

// Rows are handed to the executor in a scrambled order so that each thread's contiguous share
// of the "rows" spreads over the whole image (sky at the top and shadowed ground at the bottom
// cost differently): logical row r is image row (r · step) mod n, step ≈ 0.618 n and coprime
// with n (a Weyl sequence: any run of consecutive r covers [0, n) nearly uniformly).
inline int rowStep(int n) noexcept {
    int s = std::max(1, static_cast<int>(0.6180339887 * n));
    while (std::gcd(s, n) != 1)
        ++s;
    return s;
}
inline int rowAt(int r, int step, int n) noexcept {
    return static_cast<int>((static_cast<long long>(r) * step) % n);
}
// Image row of the shading passes' logical row r (all rows, or those of one parity).
inline int shadeRowAt(const Ctx& c, int r) noexcept {
    return c.rowParity < 0 ? rowAt(r, c.rowStepImage, c.im->H)
                           : c.rowParity + 2 * rowAt(r, c.rowStepShade, c.shadeCount);
}

struct Counts {
    std::uint64_t shadow = 0, secondary = 0;
};

inline RTCIntersectContext coherentContext() {
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    ctx.flags = RTC_INTERSECT_CONTEXT_FLAG_COHERENT;
    return ctx;
}

inline void setLane(RTCRay16& r, int k, const Vec3& o, const Vec3& d, float tfar) {
    r.org_x[k] = static_cast<float>(o.x);
    r.org_y[k] = static_cast<float>(o.y);
    r.org_z[k] = static_cast<float>(o.z);
    r.dir_x[k] = static_cast<float>(d.x);
    r.dir_y[k] = static_cast<float>(d.y);
    r.dir_z[k] = static_cast<float>(d.z);
    r.tnear[k] = 0.0f;
    r.tfar[k] = tfar;
    r.time[k] = 0.0f;
    r.mask[k] = 0xFFFFFFFFu;
    r.id[k] = 0;
    r.flags[k] = 0;
}

// A lane Embree must skip, with every field defined. The valid mask alone is not enough: where
// the CPU has no native 16-wide kernels (AVX2: two 8-wide halves; SSE: four 4-wide quarters)
// Embree traces the packet as a ray stream, which reads every lane and takes a lane as inactive
// only when tnear > tfar (Embree 3 manual, rtcIntersect1M: "A ray in a ray stream is considered
// inactive if its tnear value is larger than its tfar value"); its debug checks assert that
// each lane it traces is a valid ray. So an unused lane is a finite ray with tfar = -∞ < tnear.
inline void disableLane(RTCRay16& r, int k) {
    r.org_x[k] = 0.0f;
    r.org_y[k] = 0.0f;
    r.org_z[k] = 0.0f;
    r.dir_x[k] = 0.0f;
    r.dir_y[k] = 0.0f;
    r.dir_z[k] = 1.0f;
    r.tnear[k] = 0.0f;
    r.tfar[k] = -kInf;
    r.time[k] = 0.0f;
    r.mask[k] = 0u;
    r.id[k] = 0;
    r.flags[k] = 0;
}

// Every lane of a packet disabled, with its valid flag 0: callers then set the lanes they use.
inline void clearPacket(RTCRay16& r, int* valid) {
    for (int k = 0; k < kPacket; ++k) {
        valid[k] = 0;
        disableLane(r, k);
    }
}

inline void initHits(RTCRayHit16& rh) {
    for (int k = 0; k < kPacket; ++k) {
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
}

// Where direction d falls on the sky grid: view zenith in grid steps (clamped to the horizon)
// and azimuth (from north through east).
inline void skyGridPos(const Vec3& d, double* gz, double* az) {
    const double vzc = std::min(std::acos(std::clamp(d.z, -1.0, 1.0)), kPi / 2);
    *gz = vzc * (180.0 / kPi) / kSkyStepZ_deg;
    *az = std::atan2(d.x, d.y);
}

// Sky radiance seen along the unit direction dir (ENU; grid position gz, azimuth az), both
// bands, including the Moon's disk: bilinear in (view zenith, Δφ) on the frame's sky table,
// which is the atmosphere table's trilinear lookup at the frame's Moon zenith (the table is
// linear in each axis, so sampling it at its own nodes and interpolating gives the same).
inline void skyLookup(const Ctx& c, const float* dir, float gz, float az, float* pe,
                      float* bw) noexcept {
    if (!(c.terms & kTermInView) || dir[2] < 0.0f) {
        *pe = *bw = 0.0f;
        return;
    }
    constexpr float kTwoPiF = static_cast<float>(2.0 * kPi), kPiF = static_cast<float>(kPi);
    float a = az - c.moonAz_rad;
    if (a > kPiF) a -= kTwoPiF;
    if (a < -kPiF) a += kTwoPiF;
    const float ga = std::min(std::abs(a), kPiF) * static_cast<float>(180.0 / kPi / kSkyStepA_deg);
    const int iz = std::min(static_cast<int>(gz), kSkyZ - 2);
    const int ia = std::min(static_cast<int>(ga), kSkyA - 2);
    const float fz = gz - static_cast<float>(iz), fa = ga - static_cast<float>(ia);
    const float w00 = (1.0f - fz) * (1.0f - fa), w01 = (1.0f - fz) * fa, w10 = fz * (1.0f - fa),
                w11 = fz * fa;
    const float* t = &c.im->skyTab[static_cast<std::size_t>(iz) * kSkyA + ia];
    constexpr std::size_t kBandStride = static_cast<std::size_t>(kSkyZ) * kSkyA;
    float l[kBands];
    for (std::size_t b = 0; b < kBands; ++b) {
        const float* tb = t + b * kBandStride;
        l[b] = w00 * tb[0] + w01 * tb[1] + w10 * tb[kSkyA] + w11 * tb[kSkyA + 1];
    }
    if (dir[0] * c.moonDir[0] + dir[1] * c.moonDir[1] + dir[2] * c.moonDir[2] > c.cosMoonRadius) {
        l[0] += c.moonDisk[0];
        l[1] += c.moonDisk[1];
    }
    *pe = l[kBandPe];
    *bw = l[kBandW];
}

inline void put3(std::vector<float>& a, std::size_t i, const Vec3& v) {
    a[3 * i] = static_cast<float>(v.x);
    a[3 * i + 1] = static_cast<float>(v.y);
    a[3 * i + 2] = static_cast<float>(v.z);
}

// A hit (object geom, triangle prim, Embree's barycentrics u, v of vertices 1 and 2, distance t
// along the unit ray o + t d, geometric normal ng of either sign) → position, camera-facing unit
// normal, material, sky-view factor. Embree's hits and the OpenGL pass's (glPrimaryRows) both
// go through here.
// hitFieldsUnit: the same with the position given and ng already of unit length.
inline void hitFieldsUnit(const Renderer::Impl& im, unsigned geom, unsigned prim, double u,
                          double v, Vec3 ng, const Vec3& d, Vec3* n, int* m, double* svf) noexcept {
    const bool back = dot(ng, d) > 0.0;
    if (back) ng = -ng;
    *n = ng;
    const ObjectData& od = im.objects[geom];
    *m = od.material[prim];
    const std::size_t base = static_cast<std::size_t>(prim) * 6 + (back ? 3 : 0);
    *svf = (1.0 - u - v) * static_cast<double>(od.svf[base]) +
           u * static_cast<double>(od.svf[base + 1]) + v * static_cast<double>(od.svf[base + 2]);
}
inline void hitFields(const Renderer::Impl& im, unsigned geom, unsigned prim, double u, double v,
                      double t, const Vec3& ng, const Vec3& o, const Vec3& d, Vec3* p, Vec3* n,
                      int* m, double* svf) noexcept {
    *p = o + d * t;
    hitFieldsUnit(im, geom, prim, u, v, normalized(ng), d, n, m, svf);
}

// Hit of lane k → position, camera-facing unit normal, material, sky-view factor.
inline void hitInfo(const Renderer::Impl& im, const RTCRayHit16& rh, int k, const Vec3& o,
                    const Vec3& d, Vec3* p, Vec3* n, int* m, double* svf) noexcept {
    hitFields(im, rh.hit.geomID[k], rh.hit.primID[k], rh.hit.u[k], rh.hit.v[k],
              static_cast<double>(rh.ray.tfar[k]),
              Vec3{rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]}, o, d, p, n, m, svf);
}

// ---- The jobs' entry points (each file's banner says what it holds).
// embree_scene.cpp
void createEmbreeScene(Renderer::Impl& im, const scene::Scene& sc, const RenderConfig& config);
// light_setup.cpp
void sourceMaterialCoefficients(const scene::Scene& sc, const RenderConfig& config,
                                std::vector<double>* rhoMoon, std::vector<double>* rhoNight);
void setUpLamps(Renderer::Impl& im, const scene::Scene& sc, const RenderConfig& config);
// Places the lamps that ride on objects at im.time_s; if one moved or turned, the static data
// (its shadow rays and factors) are rebuilt for every pixel. No allocation.
void placeAttachedLamps(Renderer::Impl& im) noexcept;
void computeSkyViewFactors(Renderer::Impl& im, const RenderConfig& config);
// The static data's cover (lamps on, specular bounce) and the frame's coefficients kMoon,
// kSky, kSpec, kLamp with the active lamps.
void frameCoefficients(Renderer::Impl& im, const RenderConfig& config, const FrameSky& sky,
                       unsigned terms, const std::vector<bool>& lampOn,
                       const std::vector<double>& rhoMoon,
                       const std::vector<double>& rhoNight) noexcept;
// The frame's sky in view: the sky table and the Moon's disk in c.
void frameSkyInView(Renderer::Impl& im, const FrameSky& sky, Ctx& c) noexcept;
// primary.cpp
void setUpGl(Renderer::Impl& im, const RenderConfig& config);
void decideAuto(Renderer::Impl& im, const RenderConfig& cfg, RowExecutor& exec) noexcept;
// glRender_ms, when given: the mean of the GL draw-and-read-back part of the passes (useGl).
double timePrimaryPass(Renderer::Impl& im, const RenderConfig& cfg, bool useGl, RowExecutor& exec,
                       int reps, double* glRender_ms = nullptr) noexcept;
// Brings the G-buffer up to date for this render's rows (parity < 0: all): primary rays where
// the camera or the geometry changed, static data dropped where moving objects may change it.
void updateGeometryBuffer(Ctx& c, int parity, RowExecutor& exec) noexcept;
// shading.cpp
void shadeBatch(const Ctx& c, int count, const std::size_t* idx, bool withSky,
                float (*out)[kPacket], Counts& n) noexcept;
void shadeRows(void* vctx, int y0, int y1);
// coarse.cpp
void nodeRows(void* vctx, int j0, int j1);
void upsampleRows(void* vctx, int y0, int y1);
// point_sources.cpp: lamps and stars in view, drawn into the rows of `parity` (< 0: all).
void drawPointSources(const Renderer::Impl& im, const RenderConfig& config, const FrameSky& sky,
                      const std::vector<bool>& lampOn, unsigned terms, int parity,
                      ImageView<float> pe, ImageView<float> bandW) noexcept;

// Sky radiance for a pixel whose primary ray left the scene (direction, zenith and azimuth
// kept in the G-buffer).
inline void skyPixel(const Ctx& c, std::size_t i, int x, float* pe, float* bw) noexcept {
    const Renderer::Impl& im = *c.im;
    skyLookup(c, &im.gPos[3 * i], im.gNrm[3 * i], im.gNrm[3 * i + 1], &pe[x], &bw[x]);
}

// Shades a batch of full-rate pixels of one row into the images.
inline void flushFull(const Ctx& c, int count, const std::size_t* qi, const int* qx, float* pe,
                      float* bw, Counts& n) noexcept {
    float out[kBands][kPacket];
    shadeBatch(c, count, qi, true, out, n);
    for (int k = 0; k < count; ++k) {
        pe[qx[k]] = out[kBandPe][k];
        bw[qx[k]] = out[kBandW][k];
    }
}

// The full-rate pixels of one row waiting for a packet: shaded together when kPacket are
// queued, and the rest at the end of the row (shadeRows, upsampleRows).
struct ShadeQueue {
    std::size_t qi[kPacket];
    int qx[kPacket];
    int count = 0;

    void push(const Ctx& c, std::size_t i, int x, float* pe, float* bw, Counts& n) noexcept {
        qi[count] = i;
        qx[count++] = x;
        if (count == kPacket) {
            flushFull(c, count, qi, qx, pe, bw, n);
            count = 0;
        }
    }
    void finish(const Ctx& c, float* pe, float* bw, Counts& n) noexcept {
        if (count > 0) flushFull(c, count, qi, qx, pe, bw, n);
        count = 0;
    }
};

}  // namespace nvs::render::detail
