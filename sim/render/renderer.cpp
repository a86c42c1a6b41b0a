#include "sim/render/renderer.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "sim/sky/sky_model.h"

namespace nvs::render {

namespace {

constexpr double kPi = 3.14159265358979323846;
constexpr float kInf = std::numeric_limits<float>::infinity();
constexpr std::uint16_t kMiss = 0xFFFF;

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

}  // namespace

FrameSky frameSky(const sky::SkyModel& model, const std::array<int, kBands>& tableBand,
                  const astro::MoonState& moon) noexcept {
    FrameSky s;
    s.model = &model;
    s.tableBand = tableBand;
    s.moonAz_rad = moon.az_rad;
    s.moonZenith_rad = kPi / 2 - moon.alt_rad;
    s.moonDir_enu = enuFromAzAlt(moon.az_rad, moon.alt_rad);
    s.moonUp = moon.alt_rad > 0.0;
    s.moonAngularRadius_rad = std::asin(sky::kMoonRadius_m / moon.distanceTopocentric_m);
    const auto& t = model.table();
    for (int b = 0; b < kBands; ++b) {
        const int tb = tableBand[static_cast<std::size_t>(b)];
        const double toa = model.moonToa(tb, moon);
        s.moonToa[b] = toa;
        s.moonNormal[b] = s.moonUp ? toa * t.directTransmittance(tb, s.moonZenith_rad) : 0.0;
        s.moonSkyHorizontal[b] = toa * t.diffuseHorizontal(tb, s.moonZenith_rad);
        s.nightSkyHorizontal[b] = t.nightSkyHorizontal(tb);
    }
    return s;
}

// ------------------------------------------------------------------------------------------
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

struct Renderer::Impl {
    RTCDevice device = nullptr;
    RTCScene scene = nullptr;
    std::vector<ObjectData> objects;
    std::vector<scene::Material> materials;
    std::vector<LampData> lamps;
    // Camera
    Vec3 camPos, camFwd, camRight, camUp;
    // G-buffer
    int W = 0, H = 0;
    std::vector<float> gPos;  // xyz
    std::vector<float> gNrm;  // xyz (facing the camera)
    std::vector<float> gSvf;
    std::vector<std::uint16_t> gMat;
    std::vector<std::int16_t> gObj;
    // Coarse lighting nodes: per node [moon, lamps..., spec_pe, spec_W]
    int nodeW = 0, nodeH = 0, nodeStride = 0;
    std::vector<float> nodeLight;
    std::vector<std::uint8_t> nodeValid;
    std::atomic<std::uint64_t> primary{0}, shadow{0}, secondary{0};
    bool gValid = false;  // G-buffer matches the current camera and geometry

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
    // x grows along camRight, y along −camUp). False when the point is not in front.
    bool project(const Vec3& q, const PinholeCamera& c, double* u, double* v) const noexcept {
        const Vec3 d = q - camPos;
        const double zf = dot(d, camFwd);
        if (!(zf > 1e-6)) return false;
        *u = dot(d, camRight) / zf * c.focalLength_m / c.pitchX_m + 0.5 * c.width;
        *v = -dot(d, camUp) / zf * c.focalLength_m / c.pitchY_m + 0.5 * c.height;
        return true;
    }
};

// ------------------------------------------------------------------------------------------
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
    im.device = rtcNewDevice(nullptr);
    if (im.device == nullptr) throw SetupError("render: cannot create an Embree device");
    im.scene = rtcNewScene(im.device);
    // A static scene gets Embree's highest-quality BVH (SAH with spatial splits: about 40 %
    // more coherent packet throughput on the RIT scene than MEDIUM); with moving objects the
    // scene is rebuilt every frame, so it is marked dynamic and built at medium quality.
    bool anyMoving = false;
    for (const scene::Object& o : sc.objects)
        anyMoving = anyMoving || o.moving();
    rtcSetSceneFlags(im.scene, anyMoving ? RTC_SCENE_FLAG_DYNAMIC : RTC_SCENE_FLAG_NONE);
    rtcSetSceneBuildQuality(im.scene,
                            anyMoving ? RTC_BUILD_QUALITY_MEDIUM : RTC_BUILD_QUALITY_HIGH);

    // Geometry: one Embree triangle geometry per object, in the scene frame.
    im.objects.resize(sc.objects.size());
    for (std::size_t k = 0; k < sc.objects.size(); ++k) {
        const scene::Object& o = sc.objects[k];
        ObjectData& od = im.objects[k];
        od.obj = &o;
        od.material = o.mesh.materials;
        od.geom = rtcNewGeometry(im.device, RTC_GEOMETRY_TYPE_TRIANGLE);
        if (o.moving()) rtcSetGeometryBuildQuality(od.geom, RTC_BUILD_QUALITY_LOW);
        od.vbuf = static_cast<Vec3f*>(rtcSetNewGeometryBuffer(od.geom, RTC_BUFFER_TYPE_VERTEX, 0,
                                                              RTC_FORMAT_FLOAT3, sizeof(Vec3f),
                                                              o.mesh.vertexCount()));
        auto* ib = static_cast<std::uint32_t*>(
            rtcSetNewGeometryBuffer(od.geom, RTC_BUFFER_TYPE_INDEX, 0, RTC_FORMAT_UINT3,
                                    3 * sizeof(std::uint32_t), o.mesh.triangleCount()));
        std::copy(o.mesh.triangles.begin(), o.mesh.triangles.end(), ib);
        od.geomId = rtcAttachGeometry(im.scene, od.geom);
        rtcReleaseGeometry(od.geom);
        if (od.geomId != k) throw SetupError("render: unexpected Embree geometry id");
    }
    lampOn_.assign(sc.lamps.size(), true);
    for (std::size_t l = 0; l < sc.lamps.size(); ++l)
        lampOn_[l] = sc.lamps[l].on;
    setTime(0.0);
    setCamera(sc.camera);

    // Source-material coefficients: ρ_src,m,b = ∫S ρ w / ∫S w.
    const std::size_t nm = sc.materials.size();
    rhoMoon_.assign(nm * kBands, 0.0);
    rhoNight_.assign(nm * kBands, 0.0);
    for (std::size_t m = 0; m < nm; ++m) {
        for (int b = 0; b < kBands; ++b) {
            const Spectrum& w = config.bandWeight[static_cast<std::size_t>(b)];
            const Spectrum mw = config.moonShape * w;
            const Spectrum nw = config.nightSkyShape * w;
            const double md = mw.integrate_nm(), nd = nw.integrate_nm();
            rhoMoon_[idx(static_cast<int>(m), b)] =
                md > 0 ? integrateProduct_nm(mw, sc.materials[m].reflectance) / md : 0.0;
            rhoNight_[idx(static_cast<int>(m), b)] =
                nd > 0 ? integrateProduct_nm(nw, sc.materials[m].reflectance) / nd : 0.0;
        }
    }
    // Lamps.
    for (const scene::Lamp& l : sc.lamps) {
        LampData ld;
        ld.position = l.position_m;
        ld.axis = l.axis;
        ld.cosCutoff = std::cos(l.cutoff_rad);
        ld.aperture = l.hasAperture();
        const Spectrum glass = l.glassRadiance_W_m2_sr_nm();
        const Spectrum src = ld.aperture ? glass : l.spectralIntensity_W_sr_nm();
        ld.radius_m = ld.aperture ? 0.5 * l.apertureDiameter_m : l.bulbRadius_m;
        ld.farDistance2_m2 = 900.0 * ld.radius_m * ld.radius_m;
        if (ld.aperture) {
            // Vogel spiral: equal-area samples over the disk (each carries A/N).
            const int n = l.apertureSamples;
            const double rad = 0.5 * l.apertureDiameter_m;
            ld.sampleArea_m2 = kPi * rad * rad / n;
            Vec3 e1, e2;
            basisAround(l.axis, &e1, &e2);
            const double golden = kPi * (3.0 - std::sqrt(5.0));
            for (int k = 0; k < n; ++k) {
                const double r = rad * std::sqrt((k + 0.5) / n);
                const double ph = k * golden;
                ld.samples.push_back(l.position_m + e1 * (r * std::cos(ph)) +
                                     e2 * (r * std::sin(ph)));
            }
        }
        ld.coef.assign(nm * kBands, 0.0);
        for (int b = 0; b < kBands; ++b) {
            const Spectrum sw = src * config.bandWeight[static_cast<std::size_t>(b)];
            ld.emitted[b] = sw.integrate_nm();
            ld.glassRadiance[b] =
                integrateProduct_nm(glass, config.bandWeight[static_cast<std::size_t>(b)]);
            for (std::size_t m = 0; m < nm; ++m) {
                ld.coef[idx(static_cast<int>(m), b)] =
                    integrateProduct_nm(sw, sc.materials[m].reflectance) / kPi;
            }
        }
        im.lamps.push_back(std::move(ld));
    }

    // Sky-view factors: cosine-weighted hemisphere rays from points near each triangle corner,
    // for both sides (F = fraction of cosine-weighted directions that reach the sky; rays below
    // the horizon count as ground).
    const int nr = std::max(1, config.skyViewRays);
    for (ObjectData& od : im.objects) {
        const std::size_t nt = od.obj->mesh.triangleCount();
        od.svf.assign(nt * 6, 1.0f);
        const auto* tri = od.obj->mesh.triangles.data();
        for (std::size_t t = 0; t < nt; ++t) {
            const Vec3 a = toV(od.vbuf[tri[3 * t]]), b = toV(od.vbuf[tri[3 * t + 1]]),
                       c = toV(od.vbuf[tri[3 * t + 2]]);
            Vec3 n = cross(b - a, c - a);
            if (!(norm(n) > 0)) continue;
            n = normalized(n);
            for (int side = 0; side < 2; ++side) {
                const Vec3 ns = side == 0 ? n : -n;
                Vec3 tx, ty;
                basisAround(ns, &tx, &ty);
                for (int corner = 0; corner < 3; ++corner) {
                    const Vec3 v = corner == 0 ? a : (corner == 1 ? b : c);
                    const Vec3 p = v * 0.8 + (a + b + c) * (0.2 / 3.0) + ns * kEps_m;
                    int sky = 0;
                    const double rot =
                        2.0 * kPi *
                        static_cast<double>((t * 7 + static_cast<std::size_t>(corner)) % 13) / 13.0;
                    for (int i = 0; i < nr; ++i) {
                        double u1, u2;
                        hammersley(i, nr, &u1, &u2);
                        const double r = std::sqrt(u1), ph = 2.0 * kPi * u2 + rot;
                        const Vec3 d = tx * (r * std::cos(ph)) + ty * (r * std::sin(ph)) +
                                       ns * std::sqrt(std::max(0.0, 1.0 - u1));
                        if (d.z <= 0.0) continue;
                        if (!im.occluded(p, d, kInf)) ++sky;
                    }
                    od.svf[t * 6 + static_cast<std::size_t>(side * 3 + corner)] =
                        static_cast<float>(static_cast<double>(sky) / nr);
                }
            }
        }
    }

    // Buffers.
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
    im.nodeStride = 1 + static_cast<int>(im.lamps.size()) + 2;
    im.nodeLight.assign(maxNodes * static_cast<std::size_t>(im.nodeStride), 0.0f);
    im.nodeValid.assign(maxNodes, 0);
    setCoarseFactor(config.coarseFactor);
}

Renderer::~Renderer() = default;

void Renderer::setCoarseFactor(int f) noexcept {
    coarse_ = std::clamp(f, 1, config_.coarseFactor);
    Impl& im = *impl_;
    im.nodeW = (im.W - 1) / coarse_ + 2;
    im.nodeH = (im.H - 1) / coarse_ + 2;
}

void Renderer::setTime(double t_s) noexcept {
    Impl& im = *impl_;
    bool changed = false;
    for (ObjectData& od : im.objects) {
        const scene::Object& o = *od.obj;
        if (!o.moving() && od.placed) continue;
        od.placed = true;
        changed = true;
        Vec3 pos;
        double yaw;
        o.poseAt(t_s, &pos, &yaw);
        // Yaw turns the object's +y (its forward) toward +x (east): x' = x cos + y sin.
        const double cy = std::cos(yaw), sy = std::sin(yaw);
        const auto& v = o.mesh.vertices_m;
        for (std::size_t i = 0; i < o.mesh.vertexCount(); ++i) {
            const double x = v[3 * i], y = v[3 * i + 1], z = v[3 * i + 2];
            od.vbuf[i] = {static_cast<float>(pos.x + x * cy + y * sy),
                          static_cast<float>(pos.y - x * sy + y * cy),
                          static_cast<float>(pos.z + z)};
        }
        rtcUpdateGeometryBuffer(od.geom, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcCommitGeometry(od.geom);
    }
    if (changed) {
        rtcCommitScene(im.scene);
        im.gValid = false;
    }
}

void Renderer::setCamera(const scene::CameraPose& p) noexcept {
    Impl& im = *impl_;
    im.gValid = false;
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

// ------------------------------------------------------------------------------------------
// Shading helpers (per frame).
// ------------------------------------------------------------------------------------------
// Shading helpers (per frame). Rays go to Embree in packets of 16 (rtcIntersect16 /
// rtcOccluded16): primary rays of 16 neighbouring pixels of a row, the Moon's parallel shadow
// rays and the shadow rays toward one lamp from those pixels are coherent, which the packet
// kernels traverse together.
namespace {

constexpr int kPacket = 16;
constexpr int kTileW = 16, kTileH = 1;  // a packet's pixels
constexpr int kMaxLamps = 32;
constexpr int kMaxStride = 1 + kMaxLamps + 2;

struct Ctx {
    Renderer::Impl* im;
    const RenderConfig* cfg;
    const FrameSky* sky;
    const std::vector<double>* rhoMoon;
    const std::vector<double>* rhoNight;
    const std::vector<bool>* lampOn;
    ImageView<float> pe, bw;
    int coarse;
    unsigned terms;
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

// Sky radiance seen along the unit direction d (ENU), both bands, including the Moon's disk.
void skyRadiance(const Ctx& c, const Vec3& d, BandValues& out) noexcept {
    out = {0.0, 0.0};
    if (!(c.terms & kTermInView) || d.z < 0.0) return;
    const FrameSky& s = *c.sky;
    const double vzc = std::min(std::acos(std::clamp(d.z, -1.0, 1.0)), kPi / 2);
    const double az = std::atan2(d.x, d.y);
    const double rel = std::abs(std::remainder(az - s.moonAz_rad, 2.0 * kPi));
    for (int b = 0; b < kBands; ++b) {
        double l = 0.0;
        if (s.model != nullptr) {
            const auto& t = s.model->table();
            const int tb = s.tableBand[static_cast<std::size_t>(b)];
            l = t.nightSkyRadiance(tb, vzc);
            if (s.moonZenith_rad < 1.6755)
                l += s.moonToa[b] * t.skyRadiance(tb, vzc, rel, s.moonZenith_rad);
        } else {
            l = (s.moonSkyHorizontal[b] + s.nightSkyHorizontal[b]) / kPi;
        }
        out[b] = l;
    }
    if (s.moonUp && dot(d, s.moonDir_enu) > std::cos(s.moonAngularRadius_rad)) {
        const double omega = kPi * s.moonAngularRadius_rad * s.moonAngularRadius_rad;
        for (int b = 0; b < kBands; ++b)
            out[b] += s.moonNormal[b] / omega;
    }
}

// Direct-light geometric factors at `count` (≤ 16) points, out[k * stride + s]:
//   s = 0:      Moon, V cos θ
//   s = 1 + l:  lamp l, cos θr / r² V (point source) or Σ_k A_k cos θe cos θr / r_k² V
//               (aperture samples; visibility from lampShadowRays rays, each standing for an
//               interleaved subset of the samples)
// Returns the number of shadow rays cast.
int directFactors(const Ctx& c, int count, const Vec3* p, const Vec3* n, float* out,
                  int stride) noexcept {
    const Renderer::Impl& im = *c.im;
    const int nl = static_cast<int>(im.lamps.size());
    int rays = 0;
    int valid[kPacket];
    Vec3 o[kPacket];
    RTCRay16 r;
    for (int k = 0; k < count; ++k) {
        o[k] = p[k] + n[k] * kEps_m;
        for (int s = 0; s < 1 + nl; ++s)
            out[k * stride + s] = 0.0f;
    }
    // Moon: parallel rays.
    if (c.sky->moonUp && (c.terms & kTermMoon)) {
        float ct[kPacket];
        int any = 0;
        for (int k = 0; k < kPacket; ++k) {
            valid[k] = 0;
            if (k >= count) continue;
            ct[k] = static_cast<float>(dot(n[k], c.sky->moonDir_enu));
            if (ct[k] <= 0.0f) continue;
            valid[k] = -1;
            ++any;
            setLane(r, k, o[k], c.sky->moonDir_enu, kInf);
        }
        if (any > 0) {
            RTCIntersectContext ctx = coherentContext();
            rtcOccluded16(valid, im.scene, &ctx, &r);
            rays += any;
            for (int k = 0; k < count; ++k)
                if (valid[k] && r.tfar[k] >= 0.0f) out[k * stride] = ct[k];
        }
    }
    if (!(c.terms & kTermLamps)) return rays;
    for (int l = 0; l < nl; ++l) {
        if (!(*c.lampOn)[static_cast<std::size_t>(l)]) continue;
        const LampData& ld = im.lamps[static_cast<std::size_t>(l)];
        const int ns = ld.aperture ? static_cast<int>(ld.samples.size()) : 1;
        const int nv = ld.aperture ? std::min(ns, std::max(1, c.cfg->lampShadowRays)) : 1;
        for (int g = 0; g < nv; ++g) {
            float part[kPacket];
            int any = 0;
            for (int k = 0; k < kPacket; ++k) {
                valid[k] = 0;
                if (k >= count) continue;
                double sum = 0.0;
                if (!ld.aperture) {
                    const Vec3 d = ld.position - o[k];
                    const double r2 = dot(d, d);
                    const double rr = std::sqrt(r2);
                    const double ct = dot(n[k], d) / rr;
                    if (ct > 0.0 && -dot(d, ld.axis) / rr >= ld.cosCutoff) sum = ct / r2;
                } else if (nv == 1 &&
                           dot(ld.position - o[k], ld.position - o[k]) > ld.farDistance2_m2) {
                    // Far from the aperture (r > 30 radii): the disk's sum equals its centre
                    // term A cos θe cos θr / r² to (a/r)² ≈ 0.1 %.
                    const Vec3 d = ld.position - o[k];
                    const double r2 = dot(d, d), rr = std::sqrt(r2);
                    const double cr = dot(n[k], d) / rr;
                    const double ce = -dot(d, ld.axis) / rr;
                    if (cr > 0.0 && ce > 0.0) sum = ld.sampleArea_m2 * ns * cr * ce / r2;
                } else {
                    for (int s = g; s < ns; s += nv) {
                        const Vec3 d = ld.samples[static_cast<std::size_t>(s)] - o[k];
                        const double r2 = dot(d, d), rr = std::sqrt(r2);
                        const double cr = dot(n[k], d) / rr;
                        const double ce = -dot(d, ld.axis) / rr;
                        if (cr > 0.0 && ce > 0.0) sum += ld.sampleArea_m2 * cr * ce / r2;
                    }
                }
                if (!(sum > 0.0)) continue;
                part[k] = static_cast<float>(sum);
                const Vec3 target =
                    ld.aperture ? ld.samples[static_cast<std::size_t>(g)] : ld.position;
                const Vec3 d = target - o[k];
                const double rr = norm(d);
                valid[k] = -1;
                ++any;
                setLane(r, k, o[k], d / rr, static_cast<float>(rr * (1.0 - 1e-4)));
            }
            if (any == 0) continue;
            RTCIntersectContext ctx = coherentContext();
            rtcOccluded16(valid, im.scene, &ctx, &r);
            rays += any;
            for (int k = 0; k < count; ++k)
                if (valid[k] && r.tfar[k] >= 0.0f) out[k * stride + 1 + l] += part[k];
        }
    }
    return rays;
}

// Diffuse radiance of a surface point from its direct factors and sky-view factor.
inline void diffuseShade(const Ctx& c, int m, double svf, const float* factors,
                         BandValues& out) noexcept {
    const Renderer::Impl& im = *c.im;
    const double diffuse = 1.0 - im.materials[static_cast<std::size_t>(m)].specularity;
    const double skyOn = (c.terms & kTermSky) ? 1.0 : 0.0;
    for (int b = 0; b < kBands; ++b) {
        const std::size_t k = static_cast<std::size_t>(m) * kBands + b;
        double l = (*c.rhoMoon)[k] * c.sky->moonNormal[b] * static_cast<double>(factors[0]) / kPi;
        l += skyOn * svf *
             ((*c.rhoMoon)[k] * c.sky->moonSkyHorizontal[b] +
              (*c.rhoNight)[k] * c.sky->nightSkyHorizontal[b]) /
             kPi;
        for (std::size_t li = 0; li < im.lamps.size(); ++li)
            l += im.lamps[li].coef[k] * static_cast<double>(factors[1 + li]);
        out[b] = diffuse * l;
    }
}

// Hit of lane k → position, camera-facing unit normal, material, sky-view factor.
void hitInfo(const Renderer::Impl& im, const RTCRayHit16& rh, int k, const Vec3& o, const Vec3& d,
             Vec3* p, Vec3* n, int* m, double* svf) noexcept {
    *p = o + d * static_cast<double>(rh.ray.tfar[k]);
    Vec3 ng{rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]};
    ng = normalized(ng);
    const bool back = dot(ng, d) > 0.0;
    if (back) ng = -ng;
    *n = ng;
    const ObjectData& od = im.objects[rh.hit.geomID[k]];
    const unsigned prim = rh.hit.primID[k];
    *m = od.material[prim];
    const std::size_t base = static_cast<std::size_t>(prim) * 6 + (back ? 3 : 0);
    const double u = rh.hit.u[k], v = rh.hit.v[k];
    *svf = (1.0 - u - v) * static_cast<double>(od.svf[base]) +
           u * static_cast<double>(od.svf[base + 1]) + v * static_cast<double>(od.svf[base + 2]);
}

inline void initHits(RTCRayHit16& rh) {
    for (int k = 0; k < kPacket; ++k) {
        rh.hit.geomID[k] = RTC_INVALID_GEOMETRY_ID;
        rh.hit.instID[0][k] = RTC_INVALID_GEOMETRY_ID;
    }
}

// One specular bounce for `count` points: radiance arriving along each mirror direction
// (the diffuse radiance of what the reflected ray hits, or the sky). Returns rays cast.
int specularRadiance(const Ctx& c, int count, const Vec3* p, const Vec3* n, const Vec3* dIn,
                     BandValues* out) noexcept {
    const Renderer::Impl& im = *c.im;
    int valid[kPacket];
    Vec3 o[kPacket], r[kPacket];
    RTCRayHit16 rh;
    initHits(rh);
    for (int k = 0; k < kPacket; ++k) {
        valid[k] = k < count ? -1 : 0;
        if (k >= count) continue;
        r[k] = dIn[k] - n[k] * (2.0 * dot(dIn[k], n[k]));
        o[k] = p[k] + n[k] * kEps_m;
        setLane(rh.ray, k, o[k], r[k], kInf);
    }
    RTCIntersectContext ctx;
    rtcInitIntersectContext(&ctx);
    rtcIntersect16(valid, im.scene, &ctx, &rh);
    int rays = count;
    Vec3 q[kPacket], nq[kPacket];
    int mq[kPacket], idx[kPacket], nh = 0;
    double svf[kPacket];
    for (int k = 0; k < count; ++k) {
        if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
            skyRadiance(c, r[k], out[k]);
            continue;
        }
        hitInfo(im, rh, k, o[k], r[k], &q[nh], &nq[nh], &mq[nh], &svf[nh]);
        idx[nh++] = k;
    }
    if (nh > 0) {
        float fac[kPacket * kMaxStride];
        rays += directFactors(c, nh, q, nq, fac, kMaxStride);
        for (int h = 0; h < nh; ++h)
            diffuseShade(c, mq[h], svf[h], fac + h * kMaxStride, out[idx[h]]);
    }
    return rays;
}

// Full-rate shading of `count` G-buffer pixels (indices i[], pixel x[], row y).
void shadeFull(const Ctx& c, int count, const std::size_t* i, const int* xs, int y,
               std::uint64_t* sh, std::uint64_t* sec) noexcept {
    Renderer::Impl& im = *c.im;
    Vec3 p[kPacket], n[kPacket], d[kPacket];
    for (int k = 0; k < count; ++k) {
        p[k] = g3(im.gPos, i[k]);
        n[k] = g3(im.gNrm, i[k]);
    }
    float fac[kPacket * kMaxStride];
    *sh += static_cast<std::uint64_t>(directFactors(c, count, p, n, fac, kMaxStride));
    // Specular bounce for the specular pixels among them.
    int ns = 0, sidx[kPacket];
    Vec3 sp[kPacket], sn[kPacket];
    BandValues spec[kPacket];
    if (c.cfg->specular && (c.terms & kTermSpecular)) {
        for (int k = 0; k < count; ++k) {
            if (im.materials[im.gMat[i[k]]].specularity <= 0.0) continue;
            sidx[ns] = k;
            sp[ns] = p[k];
            sn[ns] = n[k];
            d[ns] = im.pixelDir(xs[k] + 0.5, y + 0.5, c.cfg->camera);
            ++ns;
        }
        if (ns > 0) *sec += static_cast<std::uint64_t>(specularRadiance(c, ns, sp, sn, d, spec));
    }
    int s = 0;
    float* pe = c.pe.row(y);
    float* bw = c.bw.row(y);
    for (int k = 0; k < count; ++k) {
        const int m = im.gMat[i[k]];
        BandValues l;
        diffuseShade(c, m, static_cast<double>(im.gSvf[i[k]]), fac + k * kMaxStride, l);
        if (s < ns && sidx[s] == k) {
            const double sp_ = im.materials[static_cast<std::size_t>(m)].specularity;
            for (int b = 0; b < kBands; ++b)
                l[b] += sp_ * (*c.rhoMoon)[static_cast<std::size_t>(m) * kBands + b] * spec[s][b];
            ++s;
        }
        pe[xs[k]] = static_cast<float>(l[kBandPe]);
        bw[xs[k]] = static_cast<float>(l[kBandW]);
    }
}

// Primary pass: packets of 16 pixels along a row → the G-buffer (position, normal, material,
// object, sky-view factor; kMiss where the ray leaves the scene).
void primaryRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const PinholeCamera& cam = c.cfg->camera;
    std::uint64_t prim = 0;
    for (int y = y0; y < y1; ++y) {
        for (int x0 = 0; x0 < im.W; x0 += kPacket) {
            const int count = std::min(kPacket, im.W - x0);
            int valid[kPacket];
            Vec3 d[kPacket];
            RTCRayHit16 rh;
            initHits(rh);
            for (int k = 0; k < kPacket; ++k) {
                valid[k] = k < count ? -1 : 0;
                if (k >= count) continue;
                d[k] = im.pixelDir(x0 + k + 0.5, y + 0.5, cam);
                setLane(rh.ray, k, im.camPos, d[k], kInf);
            }
            RTCIntersectContext ctx = coherentContext();
            rtcIntersect16(valid, im.scene, &ctx, &rh);
            prim += static_cast<std::uint64_t>(count);
            for (int k = 0; k < count; ++k) {
                const std::size_t i = static_cast<std::size_t>(y) * im.W + x0 + k;
                if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
                    im.gMat[i] = kMiss;
                    im.gObj[i] = -1;
                    continue;
                }
                Vec3 p, n;
                int m;
                double svf;
                hitInfo(im, rh, k, im.camPos, d[k], &p, &n, &m, &svf);
                im.gMat[i] = static_cast<std::uint16_t>(m);
                im.gObj[i] = static_cast<std::int16_t>(rh.hit.geomID[k]);
                im.gPos[3 * i] = static_cast<float>(p.x);
                im.gPos[3 * i + 1] = static_cast<float>(p.y);
                im.gPos[3 * i + 2] = static_cast<float>(p.z);
                im.gNrm[3 * i] = static_cast<float>(n.x);
                im.gNrm[3 * i + 1] = static_cast<float>(n.y);
                im.gNrm[3 * i + 2] = static_cast<float>(n.z);
                im.gSvf[i] = static_cast<float>(svf);
            }
        }
    }
    im.primary += prim;
}

// Sky radiance for the pixels whose primary ray left the scene.
inline void skyPixel(const Ctx& c, int x, int y, float* pe, float* bw) noexcept {
    BandValues l;
    skyRadiance(c, c.im->pixelDir(x + 0.5, y + 0.5, c.cfg->camera), l);
    pe[x] = static_cast<float>(l[kBandPe]);
    bw[x] = static_cast<float>(l[kBandW]);
}

// Full-rate shading of the G-buffer, 16 pixels at a time.
void shadeRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    std::uint64_t sh = 0, sec = 0;
    for (int y = y0; y < y1; ++y) {
        float* pe = c.pe.row(y);
        float* bw = c.bw.row(y);
        std::size_t qi[kPacket];
        int qx[kPacket], nq = 0;
        for (int x = 0; x < im.W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            if (im.gMat[i] == kMiss) {
                skyPixel(c, x, y, pe, bw);
                continue;
            }
            qi[nq] = i;
            qx[nq++] = x;
            if (nq == kPacket) {
                shadeFull(c, nq, qi, qx, y, &sh, &sec);
                nq = 0;
            }
        }
        if (nq > 0) shadeFull(c, nq, qi, qx, y, &sh, &sec);
    }
    im.shadow += sh;
    im.secondary += sec;
}

// Coarse nodes: direct factors and the specular radiance at every f-th pixel, 16 at a time.
void nodeRows(void* vctx, int j0, int j1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const PinholeCamera& cam = c.cfg->camera;
    const int f = c.coarse;
    const int stride = im.nodeStride;
    const int nl = static_cast<int>(im.lamps.size());
    std::uint64_t sh = 0, sec = 0;
    for (int j = j0; j < j1; ++j) {
        const int y = std::min(j * f, im.H - 1);
        for (int k0 = 0; k0 < im.nodeW; k0 += kPacket) {
            Vec3 p[kPacket], n[kPacket], d[kPacket], sp[kPacket], sn[kPacket];
            std::size_t ni[kPacket];
            int nh = 0, ns = 0, sidx[kPacket];
            for (int k = k0; k < std::min(k0 + kPacket, im.nodeW); ++k) {
                const int x = std::min(k * f, im.W - 1);
                const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
                const std::size_t node = static_cast<std::size_t>(j) * im.nodeW + k;
                im.nodeValid[node] = im.gMat[i] != kMiss;
                if (im.gMat[i] == kMiss) continue;
                p[nh] = g3(im.gPos, i);
                n[nh] = g3(im.gNrm, i);
                ni[nh] = node;
                float* spec = &im.nodeLight[node * static_cast<std::size_t>(stride)] + 1 + nl;
                spec[0] = spec[1] = 0.0f;
                if (c.cfg->specular && (c.terms & kTermSpecular) &&
                    im.materials[im.gMat[i]].specularity > 0.0) {
                    sidx[ns] = nh;
                    sp[ns] = p[nh];
                    sn[ns] = n[nh];
                    d[ns] = im.pixelDir(x + 0.5, y + 0.5, cam);
                    ++ns;
                }
                ++nh;
            }
            if (nh == 0) continue;
            float fac[kPacket * kMaxStride];
            sh += static_cast<std::uint64_t>(directFactors(c, nh, p, n, fac, kMaxStride));
            for (int h = 0; h < nh; ++h) {
                float* out = &im.nodeLight[ni[h] * static_cast<std::size_t>(stride)];
                std::copy(fac + h * kMaxStride, fac + h * kMaxStride + 1 + nl, out);
            }
            if (ns > 0) {
                BandValues spec[kPacket];
                sec += static_cast<std::uint64_t>(specularRadiance(c, ns, sp, sn, d, spec));
                for (int s = 0; s < ns; ++s) {
                    float* out =
                        &im.nodeLight[ni[sidx[s]] * static_cast<std::size_t>(stride)] + 1 + nl;
                    out[0] = static_cast<float>(spec[s][0]);
                    out[1] = static_cast<float>(spec[s][1]);
                }
            }
        }
    }
    im.shadow += sh;
    im.secondary += sec;
}

// Upsampling guided by the full-resolution geometry; pixels with no node on their surface are
// shaded at full rate (16 at a time). Single precision: the weights and the tests need none
// better, and the loop runs for every pixel.
void upsampleRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const int f = c.coarse;
    const float invF = 1.0f / static_cast<float>(f);
    const int ns = im.nodeStride;
    const float cx = static_cast<float>(im.camPos.x), cy = static_cast<float>(im.camPos.y),
                cz = static_cast<float>(im.camPos.z);
    std::uint64_t sh = 0, sec = 0;
    float acc[kMaxStride];
    for (int y = y0; y < y1; ++y) {
        float* pe = c.pe.row(y);
        float* bw = c.bw.row(y);
        const int j = y / f;
        const float fy = static_cast<float>(y - j * f) * invF;
        const int jj[2] = {j, std::min(j + 1, im.nodeH - 1)};
        const int nyRow[2] = {std::min(jj[0] * f, im.H - 1), std::min(jj[1] * f, im.H - 1)};
        std::size_t qi[kPacket];
        int qx[kPacket], nq = 0;
        for (int x = 0; x < im.W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            const int m = im.gMat[i];
            if (m == kMiss) {
                skyPixel(c, x, y, pe, bw);
                continue;
            }
            const float* pp = &im.gPos[3 * i];
            const float* pn = &im.gNrm[3 * i];
            const float dx = pp[0] - cx, dy = pp[1] - cy, dz = pp[2] - cz;
            const float planeTol = 0.02f + 2e-3f * std::sqrt(dx * dx + dy * dy + dz * dz);
            const int k = x / f;
            const float fx = static_cast<float>(x - k * f) * invF;
            const int kk[2] = {k, std::min(k + 1, im.nodeW - 1)};
            for (int s = 0; s < ns; ++s)
                acc[s] = 0.0f;
            float wsum = 0.0f;
            const std::int16_t obj = im.gObj[i];
            for (int dj = 0; dj < 2; ++dj) {
                for (int dk = 0; dk < 2; ++dk) {
                    const std::size_t ni = static_cast<std::size_t>(jj[dj]) * im.nodeW + kk[dk];
                    if (!im.nodeValid[ni]) continue;
                    const std::size_t q =
                        static_cast<std::size_t>(nyRow[dj]) * im.W + std::min(kk[dk] * f, im.W - 1);
                    if (im.gObj[q] != obj || im.gMat[q] != m) continue;
                    const float* qn = &im.gNrm[3 * q];
                    if (qn[0] * pn[0] + qn[1] * pn[1] + qn[2] * pn[2] < 0.95f) continue;
                    const float* qp = &im.gPos[3 * q];
                    const float off =
                        (qp[0] - pp[0]) * pn[0] + (qp[1] - pp[1]) * pn[1] + (qp[2] - pp[2]) * pn[2];
                    if (std::abs(off) > planeTol) continue;
                    const float w = (dk ? fx : 1.0f - fx) * (dj ? fy : 1.0f - fy) + 1e-6f;
                    const float* src = &im.nodeLight[ni * static_cast<std::size_t>(ns)];
                    for (int s = 0; s < ns; ++s)
                        acc[s] += w * src[s];
                    wsum += w;
                }
            }
            if (!(wsum > 0.0f)) {
                // No sample on this surface nearby: full rate here.
                qi[nq] = i;
                qx[nq++] = x;
                if (nq == kPacket) {
                    shadeFull(c, nq, qi, qx, y, &sh, &sec);
                    nq = 0;
                }
                continue;
            }
            const float inv = 1.0f / wsum;
            for (int s = 0; s < ns; ++s)
                acc[s] *= inv;
            BandValues l;
            diffuseShade(c, m, static_cast<double>(im.gSvf[i]), acc, l);
            const double sp = im.materials[static_cast<std::size_t>(m)].specularity;
            if (sp > 0.0) {
                for (int b = 0; b < kBands; ++b) {
                    l[b] += sp * (*c.rhoMoon)[static_cast<std::size_t>(m) * kBands + b] *
                            static_cast<double>(acc[ns - 2 + b]);
                }
            }
            pe[x] = static_cast<float>(l[kBandPe]);
            bw[x] = static_cast<float>(l[kBandW]);
        }
        if (nq > 0) shadeFull(c, nq, qi, qx, y, &sh, &sec);
    }
    im.shadow += sh;
    im.secondary += sec;
}

}  // namespace

void Renderer::render(const FrameSky& sky, ImageView<float> pe, ImageView<float> bandW,
                      RowExecutor& exec) noexcept {
    Impl& im = *impl_;
    if (pe.width() != im.W || pe.height() != im.H || bandW.width() != im.W ||
        bandW.height() != im.H || im.lamps.size() > static_cast<std::size_t>(kMaxLamps)) {
        return;
    }
    im.primary = 0;
    im.shadow = 0;
    im.secondary = 0;
    Ctx c{&im, &config_, &sky, &rhoMoon_, &rhoNight_, &lampOn_, pe, bandW, coarse_, terms_};
    // The primary rays depend only on the camera and the geometry: with neither changed since
    // the last frame (a fixed camera over a static scene), the G-buffer is reused.
    if (!im.gValid) {
        exec.run(im.H, &primaryRows, &c);
        im.gValid = true;
    }
    if (coarse_ > 1) {
        exec.run(im.nodeH, &nodeRows, &c);
        exec.run(im.H, &upsampleRows, &c);
    } else {
        exec.run(im.H, &shadeRows, &c);
    }
    // Lamps in view: each lamp's light reaching the lens, spread over the pixel it falls in
    // (I / r² / Ω_pixel: the pixel-mean radiance of a source smaller than a pixel).
    const PinholeCamera& cam = config_.camera;
    const double omegaPixel = cam.pitchX_m * cam.pitchY_m / (cam.focalLength_m * cam.focalLength_m);
    for (std::size_t l = 0; l < im.lamps.size() && (terms_ & kTermInView); ++l) {
        if (!lampOn_[l]) continue;
        const LampData& ld = im.lamps[l];
        const Vec3 d = ld.position - im.camPos;
        const double r = norm(d);
        if (!(r > 1e-6)) continue;
        const Vec3 dn = d / r;
        double u, v;
        if (!im.project(ld.position, cam, &u, &v)) continue;
        if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
        const double ce = -dot(dn, ld.axis);
        double intensityScale;  // ∫ I w toward the camera / emitted band value
        if (ld.aperture) {
            if (ce <= 0.0) continue;
            intensityScale = ld.sampleArea_m2 * static_cast<double>(ld.samples.size()) * ce;
        } else {
            if (ce < ld.cosCutoff) continue;
            intensityScale = 1.0;
        }
        if (im.occluded(im.camPos, dn, static_cast<float>(r - ld.radius_m - 1e-3))) continue;
        const int px = static_cast<int>(u), py = static_cast<int>(v);
        const double toPixel = intensityScale / (r * r) / omegaPixel;
        pe(px, py) += static_cast<float>(ld.emitted[kBandPe] * toPixel);
        bandW(px, py) += static_cast<float>(ld.emitted[kBandW] * toPixel);
    }
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

double Renderer::measureEmbreePrimaryRate(int repetitions) const {
    const Impl& im = *impl_;
    const PinholeCamera& cam = config_.camera;
    std::uint64_t hits = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < repetitions; ++r) {
        for (int y = 0; y < im.H; ++y) {
            for (int x = 0; x < im.W; ++x) {
                RTCRayHit rh;
                hits += im.intersect(im.camPos, im.pixelDir(x + 0.5, y + 0.5, cam), &rh) ? 1u : 0u;
            }
        }
    }
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    (void)hits;
    return static_cast<double>(repetitions) * im.W * im.H / dt;
}

double Renderer::measureEmbreePacketRate(int repetitions) const {
    const Impl& im = *impl_;
    const PinholeCamera& cam = config_.camera;
    std::uint64_t hits = 0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < repetitions; ++r) {
        for (int y0 = 0; y0 < im.H; y0 += kTileH) {
            for (int x0 = 0; x0 < im.W; x0 += kTileW) {
                int valid[kPacket];
                RTCRayHit16 rh;
                initHits(rh);
                for (int k = 0; k < kPacket; ++k) {
                    const int x = x0 + k % kTileW, y = y0 + k / kTileW;
                    valid[k] = x < im.W && y < im.H ? -1 : 0;
                    setLane(rh.ray, k, im.camPos, im.pixelDir(x + 0.5, y + 0.5, cam), kInf);
                }
                RTCIntersectContext ctx = coherentContext();
                rtcIntersect16(valid, im.scene, &ctx, &rh);
                for (int k = 0; k < kPacket; ++k)
                    hits += valid[k] && rh.hit.geomID[k] != RTC_INVALID_GEOMETRY_ID ? 1u : 0u;
            }
        }
    }
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    (void)hits;
    return static_cast<double>(repetitions) * im.W * im.H / dt;
}

void Renderer::setObjectEnabled(int object, bool enabled) noexcept {
    Impl& im = *impl_;
    if (object < 0 || static_cast<std::size_t>(object) >= im.objects.size()) return;
    RTCGeometry g = im.objects[static_cast<std::size_t>(object)].geom;
    if (enabled) {
        rtcEnableGeometry(g);
    } else {
        rtcDisableGeometry(g);
    }
    rtcCommitScene(im.scene);
    im.gValid = false;
}

}  // namespace nvs::render
