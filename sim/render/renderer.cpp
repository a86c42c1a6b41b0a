#include "sim/render/renderer.h"

#include <embree3/rtcore.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <limits>
#include <numeric>
#include <string>

#include "sim/core/cpu_isa.h"
#include "sim/render/gl_visibility.h"

namespace nvs::render {

namespace {

constexpr double kPi = 3.14159265358979323846;
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

}  // namespace

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

namespace {

// The OpenGL pass for primary visibility, every object's mesh in it with its Embree geometry
// id. "gl" without a working backend is a setup error; "auto" then stays on Embree.
void setUpGl(Renderer::Impl& im, const RenderConfig& config) {
    const bool required = config.primaryVisibility == PrimaryVisibility::kGl;
    im.gl = GlVisibility::create(GlBackendChoice::kAuto, config.camera.width, config.camera.height,
                                 &im.glReason);
    if (!im.gl) {
        if (required) {
            throw SetupError("render: primary_visibility = \"gl\": no OpenGL backend (" +
                             im.glReason + ")");
        }
        return;
    }
    for (const ObjectData& od : im.objects) {
        const scene::Mesh& mesh = od.obj->mesh;
        im.gl->addMesh(reinterpret_cast<const float*>(od.vbuf), mesh.vertexCount(),
                       mesh.triangles.data(), mesh.triangleCount(), od.geomId);
    }
    im.glStale.assign(im.objects.size(), 0);
    im.useGl = required;
    im.autoPending = !required;
}

}  // namespace

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
    // Embree's kernel set: its own choice, or the pinned one (sim/core/cpu_isa.h).
    const std::string deviceConfig = embreeDeviceConfig(config.embreeIsa);
    im.device = rtcNewDevice(deviceConfig.empty() ? nullptr : deviceConfig.c_str());
    if (im.device == nullptr) {
        throw SetupError("render: cannot create an Embree device" +
                         (deviceConfig.empty() ? std::string() : " (" + deviceConfig + ")"));
    }
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

void Renderer::setTime(double t_s) noexcept {
    Impl& im = *impl_;
    bool changed = false, firstPlacement = false;
    for (ObjectData& od : im.objects) {
        const scene::Object& o = *od.obj;
        if (!o.moving() && od.placed) continue;
        const bool wasPlaced = od.placed;
        od.placed = true;
        Vec3 pos;
        double yaw;
        o.poseAt(t_s, &pos, &yaw);
        // Yaw turns the object's +y (its forward) toward +x (east): x' = x cos + y sin.
        const double cy = std::cos(yaw), sy = std::sin(yaw);
        const auto& v = o.mesh.vertices_m;
        bool moved = false;
        Vec3 lo{kInf, kInf, kInf}, hi{-kInf, -kInf, -kInf};
        const auto grow = [&](const Vec3f& q) {
            lo = {std::min(lo.x, double{q.x}), std::min(lo.y, double{q.y}),
                  std::min(lo.z, double{q.z})};
            hi = {std::max(hi.x, double{q.x}), std::max(hi.y, double{q.y}),
                  std::max(hi.z, double{q.z})};
        };
        for (std::size_t i = 0; i < o.mesh.vertexCount(); ++i) {
            const double x = v[3 * i], y = v[3 * i + 1], z = v[3 * i + 2];
            const Vec3f q{static_cast<float>(pos.x + x * cy + y * sy),
                          static_cast<float>(pos.y - x * sy + y * cy),
                          static_cast<float>(pos.z + z)};
            if (wasPlaced) {
                const Vec3f& old = od.vbuf[i];
                moved = moved || old.x != q.x || old.y != q.y || old.z != q.z;
                grow(old);
            }
            grow(q);
            od.vbuf[i] = q;
        }
        if (wasPlaced && !moved) continue;  // parked: nothing to redo
        changed = true;
        if (!wasPlaced) {
            firstPlacement = true;
        } else if (im.nDirty < Impl::kMaxDirty) {
            im.dirtyLo[im.nDirty] = lo;
            im.dirtyHi[im.nDirty++] = hi;
        } else {
            firstPlacement = true;  // too many boxes: redo everything
        }
        rtcUpdateGeometryBuffer(od.geom, RTC_BUFFER_TYPE_VERTEX, 0);
        rtcCommitGeometry(od.geom);
        if (!im.glStale.empty()) im.glStale[od.geomId] = 1;  // uploaded by the next GL pass
    }
    if (changed) {
        rtcCommitScene(im.scene);
        if (firstPlacement) im.gValidRows = 0;
    }
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

// ------------------------------------------------------------------------------------------
// Shading (per frame). Rays go to Embree in packets of 16 (rtcIntersect16 / rtcOccluded16):
// the points of 16 neighbouring pixels of a row, whose Moon shadow rays (parallel), shadow rays
// toward one lamp and mirror rays are coherent, which the packet kernels traverse together.
//
// The work is split by what it depends on:
//   static (geometry, camera, lamp placement): the G-buffer, the lamp factors (shadow rays to
//     the lamps, inverse square, cosines) and the specular ray's hit with its own lamp factors,
//     and the upsampling weights of the coarse tiles. Kept while the camera and the geometry
//     stay (a fixed camera over a static scene computes them once);
//   per frame (Moon, sky, lamp switches): the Moon's shadow rays, the sky radiance, and the
//     sums with per-(material, band) coefficients computed once per frame.
// Radiance of a hit pixel with material m (docs/render.md):
//   L_b = kMoon_m,b V☾ cos θ☾ + Σ_l kLamp_l,m,b f_l + kSky_m,b F + kSpec_m,b L_spec,b
//   kMoon = (1−s) ρ☾ E☾ / π, kLamp = (1−s) C_l,m (0 while off), kSky = (1−s)(ρ☾ E_sky☾ +
//   ρ_n E_night) / π, kSpec = s ρ☾; L_spec is the same sum at the mirror ray's hit, or the sky.
// ------------------------------------------------------------------------------------------
namespace {

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

// Lamp factors at `count` (≤ 16) points for the lamps in `mask`, out[k nl + l]:
//   cos θr / r² V                        (point source)
//   Σ_k A_k cos θe cos θr / r_k² V       (aperture samples; visibility from lampShadowRays
//                                         rays, each standing for an interleaved subset)
// 0 for lamps not in the mask. Returns the number of shadow rays cast.
int lampFactors(const Renderer::Impl& im, const RenderConfig& cfg, std::uint64_t mask, int count,
                const Vec3* p, const Vec3* n, float* out) noexcept {
    const int nl = static_cast<int>(im.lamps.size());
    int rays = 0;
    alignas(64) int valid[kPacket];  // Embree: a packet's valid mask is 64-byte aligned
    Vec3 o[kPacket];
    RTCRay16 r;
    for (int k = 0; k < count; ++k) {
        o[k] = p[k] + n[k] * kEps_m;
        for (int l = 0; l < nl; ++l)
            out[k * nl + l] = 0.0f;
    }
    for (int l = 0; l < nl; ++l) {
        if (!(mask & (std::uint64_t{1} << l))) continue;
        const LampData& ld = im.lamps[static_cast<std::size_t>(l)];
        const int ns = ld.aperture ? static_cast<int>(ld.samples.size()) : 1;
        const int nv = ld.aperture ? std::min(ns, std::max(1, cfg.lampShadowRays)) : 1;
        for (int g = 0; g < nv; ++g) {
            float part[kPacket];
            int any = 0;
            clearPacket(r, valid);
            for (int k = 0; k < count; ++k) {
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
                if (valid[k] && r.tfar[k] >= 0.0f) out[k * nl + l] += part[k];
        }
    }
    return rays;
}

// Moon factor V cos θ☾ at the points with use[k] (0 elsewhere): parallel shadow rays.
// Returns the number of rays cast.
int moonFactors(const Ctx& c, int count, const Vec3* p, const Vec3* n, const bool* use,
                float* out) noexcept {
    const Vec3& md = c.sky->moonDir_enu;
    alignas(64) int valid[kPacket];  // Embree: a packet's valid mask is 64-byte aligned
    RTCRay16 r;
    int any = 0;
    clearPacket(r, valid);
    for (int k = 0; k < count; ++k) {
        out[k] = 0.0f;
        if (!use[k]) continue;
        const double ct = dot(n[k], md);
        if (ct <= 0.0) continue;
        out[k] = static_cast<float>(ct);
        valid[k] = -1;
        ++any;
        setLane(r, k, p[k] + n[k] * kEps_m, md, kInf);
    }
    if (any == 0) return 0;
    RTCIntersectContext ctx = coherentContext();
    rtcOccluded16(valid, c.im->scene, &ctx, &r);
    for (int k = 0; k < count; ++k)
        if (valid[k] && r.tfar[k] < 0.0f) out[k] = 0.0f;
    return any;
}

// A hit (object geom, triangle prim, Embree's barycentrics u, v of vertices 1 and 2, distance t
// along the unit ray o + t d, geometric normal ng of either sign) → position, camera-facing unit
// normal, material, sky-view factor. Embree's hits and the OpenGL pass's (glPrimaryRows) both
// go through here.
void hitFields(const Renderer::Impl& im, unsigned geom, unsigned prim, double u, double v, double t,
               Vec3 ng, const Vec3& o, const Vec3& d, Vec3* p, Vec3* n, int* m,
               double* svf) noexcept {
    *p = o + d * t;
    ng = normalized(ng);
    const bool back = dot(ng, d) > 0.0;
    if (back) ng = -ng;
    *n = ng;
    const ObjectData& od = im.objects[geom];
    *m = od.material[prim];
    const std::size_t base = static_cast<std::size_t>(prim) * 6 + (back ? 3 : 0);
    *svf = (1.0 - u - v) * static_cast<double>(od.svf[base]) +
           u * static_cast<double>(od.svf[base + 1]) + v * static_cast<double>(od.svf[base + 2]);
}

// Hit of lane k → position, camera-facing unit normal, material, sky-view factor.
void hitInfo(const Renderer::Impl& im, const RTCRayHit16& rh, int k, const Vec3& o, const Vec3& d,
             Vec3* p, Vec3* n, int* m, double* svf) noexcept {
    hitFields(im, rh.hit.geomID[k], rh.hit.primID[k], rh.hit.u[k], rh.hit.v[k],
              static_cast<double>(rh.ray.tfar[k]),
              Vec3{rh.hit.Ng_x[k], rh.hit.Ng_y[k], rh.hit.Ng_z[k]}, o, d, p, n, m, svf);
}

inline void put3(std::vector<float>& a, std::size_t i, const Vec3& v) {
    a[3 * i] = static_cast<float>(v.x);
    a[3 * i + 1] = static_cast<float>(v.y);
    a[3 * i + 2] = static_cast<float>(v.z);
}

// Static data of `count` (≤ 16) hit pixels: lamp factors, and for specular materials the
// mirror ray's hit (or its sky direction) with the lamp factors there.
void buildStatic(const Ctx& c, int count, const std::size_t* idx, Counts& n) noexcept {
    Renderer::Impl& im = *c.im;
    const std::size_t nl = im.lamps.size();
    const std::uint64_t need = im.staticNeed;
    Vec3 p[kPacket], nn[kPacket];
    for (int k = 0; k < count; ++k) {
        p[k] = g3(im.gPos, idx[k]);
        nn[k] = g3(im.gNrm, idx[k]);
    }
    float fac[kPacket * kMaxLampsStatic];
    if ((need & ~kSpecBit) != 0) {  // the lamps the static data covers (≥ those on now)
        n.shadow += static_cast<std::uint64_t>(lampFactors(im, *c.cfg, need, count, p, nn, fac));
        for (int k = 0; k < count; ++k)
            std::copy(fac + static_cast<std::size_t>(k) * nl,
                      fac + static_cast<std::size_t>(k + 1) * nl, im.sLamp.data() + idx[k] * nl);
    }
    // Mirror rays of the specular pixels among them.
    alignas(64) int valid[kPacket];  // Embree: a packet's valid mask is 64-byte aligned
    int ns = 0, sk[kPacket];
    Vec3 o[kPacket], r[kPacket];
    RTCRayHit16 rh;
    initHits(rh);
    clearPacket(rh.ray, valid);
    for (int k = 0; k < count; ++k) {
        const std::size_t i = idx[k];
        im.sValid[i] = 1;
        im.sqMat[i] = kNotSpecular;
        if (!(need & kSpecBit) || !(im.materials[im.gMat[i]].specularity > 0.0)) {
            continue;
        }
        const int x = static_cast<int>(i % static_cast<std::size_t>(im.W));
        const int y = static_cast<int>(i / static_cast<std::size_t>(im.W));
        const Vec3 dIn = im.pixelDir(x + 0.5, y + 0.5, c.cfg->camera);
        r[ns] = dIn - nn[k] * (2.0 * dot(dIn, nn[k]));
        o[ns] = p[k] + nn[k] * kEps_m;
        setLane(rh.ray, ns, o[ns], r[ns], kInf);
        valid[ns] = -1;
        sk[ns++] = k;
    }
    if (ns == 0) return;
    // Mirror rays of neighbouring pixels on one surface are as coherent as the primary rays.
    RTCIntersectContext ctx = coherentContext();
    rtcIntersect16(valid, im.scene, &ctx, &rh);
    n.secondary += static_cast<std::uint64_t>(ns);
    Vec3 q[kPacket], nq[kPacket];
    std::size_t qi[kPacket];
    int nh = 0;
    for (int s = 0; s < ns; ++s) {
        const std::size_t i = idx[sk[s]];
        if (rh.hit.geomID[s] == RTC_INVALID_GEOMETRY_ID) {
            double gz, az;
            skyGridPos(r[s], &gz, &az);
            im.sqMat[i] = kMiss;
            put3(im.sqPos, i, r[s]);
            put3(im.sqNrm, i, Vec3{gz, az, 0.0});
            continue;
        }
        int m;
        double svf;
        hitInfo(im, rh, s, o[s], r[s], &q[nh], &nq[nh], &m, &svf);
        im.sqMat[i] = static_cast<std::uint16_t>(m);
        put3(im.sqPos, i, q[nh]);
        put3(im.sqNrm, i, nq[nh]);
        im.sqSvf[i] = static_cast<float>(svf);
        qi[nh++] = i;
    }
    if (nh > 0 && nl > 0) {
        n.secondary += static_cast<std::uint64_t>(lampFactors(im, *c.cfg, need, nh, q, nq, fac));
        for (int h = 0; h < nh; ++h)
            std::copy(fac + static_cast<std::size_t>(h) * nl,
                      fac + static_cast<std::size_t>(h + 1) * nl, im.sqLamp.data() + qi[h] * nl);
    }
}

// Radiance of `count` (≤ 16) hit pixels, out[b][k]; with the sky term when withSky (coarse
// nodes leave it to each pixel, whose sky-view factor it needs).
void shadeBatch(const Ctx& c, int count, const std::size_t* idx, bool withSky,
                float (*out)[kPacket], Counts& n) noexcept {
    Renderer::Impl& im = *c.im;
    {
        std::size_t bi[kPacket];
        int nb = 0;
        for (int k = 0; k < count; ++k)
            if (!im.sValid[idx[k]]) bi[nb++] = idx[k];
        if (nb > 0) buildStatic(c, nb, bi, n);
    }
    float moonF[kPacket], moonQ[kPacket];
    for (int k = 0; k < kPacket; ++k)
        moonF[k] = moonQ[k] = 0.0f;
    if (c.moonOn) {
        Vec3 p[kPacket], nn[kPacket];
        bool use[kPacket] = {};
        bool anyQ = false;
        for (int k = 0; k < count; ++k) {
            p[k] = g3(im.gPos, idx[k]);
            nn[k] = g3(im.gNrm, idx[k]);
            use[k] = true;
        }
        n.shadow += static_cast<std::uint64_t>(moonFactors(c, count, p, nn, use, moonF));
        for (int k = 0; k < count; ++k) {
            use[k] = im.sqMat[idx[k]] < kNotSpecular;
            if (!use[k]) continue;
            anyQ = true;
            p[k] = g3(im.sqPos, idx[k]);
            nn[k] = g3(im.sqNrm, idx[k]);
        }
        if (anyQ)
            n.secondary += static_cast<std::uint64_t>(moonFactors(c, count, p, nn, use, moonQ));
    }
    const std::size_t nl = im.lamps.size();
    const std::size_t nmb = im.materials.size() * kBands;
    for (int k = 0; k < count; ++k) {
        const std::size_t i = idx[k];
        const std::size_t m = im.gMat[i];
        const float* fl = im.sLamp.data() + i * nl;  // no lamps: empty, data() + 0
        const std::uint16_t qm = im.sqMat[i];
        float specL[kBands] = {0.0f, 0.0f};
        if (qm != kNotSpecular && im.kSpec[m * kBands] != 0.0f) {
            if (qm == kMiss) {
                skyLookup(c, &im.sqPos[3 * i], im.sqNrm[3 * i], im.sqNrm[3 * i + 1],
                          &specL[kBandPe], &specL[kBandW]);
            } else {
                const float* ql = im.sqLamp.data() + i * nl;
                for (std::size_t b = 0; b < kBands; ++b) {
                    const std::size_t mb = qm * std::size_t{kBands} + b;
                    float l = im.kMoon[mb] * moonQ[k] + im.kSky[mb] * im.sqSvf[i];
                    for (int a = 0; a < im.activeLamps; ++a) {
                        const auto li = static_cast<std::size_t>(im.activeLamp[a]);
                        l += im.kLamp[li * nmb + mb] * ql[li];
                    }
                    specL[b] = l;
                }
            }
        }
        for (std::size_t b = 0; b < kBands; ++b) {
            const std::size_t mb = m * kBands + b;
            float l = im.kMoon[mb] * moonF[k] + im.kSpec[mb] * specL[b];
            if (withSky) l += im.kSky[mb] * im.gSvf[i];
            for (int a = 0; a < im.activeLamps; ++a) {
                const auto li = static_cast<std::size_t>(im.activeLamp[a]);
                l += im.kLamp[li * nmb + mb] * fl[li];
            }
            out[b][k] = l;
        }
    }
}

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

// Primary pass: packets of 16 pixels along a row → the G-buffer (position, normal, material,
// object, sky-view factor; kMiss where the ray leaves the scene, with its direction, zenith
// and azimuth in place of position and normal). Resets the pixels' static data.
void primaryRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const PinholeCamera& cam = c.cfg->camera;
    std::uint64_t prim = 0;
    for (int yr = y0; yr < y1; ++yr) {
        const int y = c.rowLo + c.rowStride * rowAt(yr, c.rowStepRect, c.rowCount);
        for (int x0 = c.colLo; x0 < c.colHi; x0 += kPacket) {
            const int count = std::min(kPacket, c.colHi - x0);
            alignas(64) int valid[kPacket];  // Embree: a packet's valid mask is 64-byte aligned
            Vec3 d[kPacket];
            RTCRayHit16 rh;
            initHits(rh);
            clearPacket(rh.ray, valid);
            for (int k = 0; k < count; ++k) {
                valid[k] = -1;
                d[k] = im.pixelDir(x0 + k + 0.5, y + 0.5, cam);
                setLane(rh.ray, k, im.camPos, d[k], kInf);
            }
            RTCIntersectContext ctx = coherentContext();
            rtcIntersect16(valid, im.scene, &ctx, &rh);
            prim += static_cast<std::uint64_t>(count);
            for (int k = 0; k < count; ++k) {
                const std::size_t i = static_cast<std::size_t>(y) * im.W + x0 + k;
                im.sValid[i] = 0;
                if (rh.hit.geomID[k] == RTC_INVALID_GEOMETRY_ID) {
                    double gz, az;
                    skyGridPos(d[k], &gz, &az);
                    im.gMat[i] = kMiss;
                    im.gObj[i] = -1;
                    put3(im.gPos, i, d[k]);
                    put3(im.gNrm, i, Vec3{gz, az, 0.0});
                    continue;
                }
                Vec3 p, n;
                int m;
                double svf;
                hitInfo(im, rh, k, im.camPos, d[k], &p, &n, &m, &svf);
                im.gMat[i] = static_cast<std::uint16_t>(m);
                im.gObj[i] = static_cast<std::int16_t>(rh.hit.geomID[k]);
                put3(im.gPos, i, p);
                put3(im.gNrm, i, n);
                im.gSvf[i] = static_cast<float>(svf);
            }
        }
    }
    im.primary += prim;
}

// The G-buffer of the pass's rectangle from the OpenGL pass's hits (gl_visibility.h): the same
// fields as primaryRows, through hitFields, from (geomId, primId, u, v, t) per pixel. The
// geometric normal is Embree's for the triangle, Ng = e2 × e1 with e1 = v0 − v1, e2 = v2 − v0,
// that is (v1 − v0) × (v2 − v0) (Embree 3, kernels/geometry/triangle_intersector_moeller.h),
// so a hit's side, and with it the side's sky-view factors, is the one Embree's hit gives (the
// test GlPrimary.* compares them).
void glPrimaryRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const PinholeCamera& cam = c.cfg->camera;
    const std::uint32_t* ids = im.gl->ids();
    const float* dist_m = im.gl->distances_m();
    for (int yr = y0; yr < y1; ++yr) {
        const int y = c.rowLo + c.rowStride * rowAt(yr, c.rowStepRect, c.rowCount);
        for (int x = c.colLo; x < c.colHi; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            im.sValid[i] = 0;
            const Vec3 d = im.pixelDir(x + 0.5, y + 0.5, cam);
            const std::uint32_t* w = &ids[4 * i];
            const std::uint32_t geom = w[2] - 1u, prim = w[3];
            if (w[2] == 0 || geom >= im.objects.size() ||
                prim >= im.objects[geom].material.size()) {
                double gz, az;
                skyGridPos(d, &gz, &az);
                im.gMat[i] = kMiss;
                im.gObj[i] = -1;
                put3(im.gPos, i, d);
                put3(im.gNrm, i, Vec3{gz, az, 0.0});
                continue;
            }
            const ObjectData& od = im.objects[geom];
            const std::uint32_t* tri = &od.obj->mesh.triangles[3 * static_cast<std::size_t>(prim)];
            const Vec3 a = toV(od.vbuf[tri[0]]), b = toV(od.vbuf[tri[1]]), e = toV(od.vbuf[tri[2]]);
            float u, v;
            std::memcpy(&u, &w[0], sizeof u);
            std::memcpy(&v, &w[1], sizeof v);
            Vec3 p, n;
            int m;
            double svf;
            hitFields(im, geom, prim, u, v, static_cast<double>(dist_m[i]), cross(b - a, e - a),
                      im.camPos, d, &p, &n, &m, &svf);
            im.gMat[i] = static_cast<std::uint16_t>(m);
            im.gObj[i] = static_cast<std::int16_t>(geom);
            put3(im.gPos, i, p);
            put3(im.gNrm, i, n);
            im.gSvf[i] = static_cast<float>(svf);
        }
    }
}

// The primary pass over the context's rectangle: OpenGL (after uploading the objects that moved)
// when it is in use, else, or if the GL pass fails, Embree's primary rays.
void primaryPass(Ctx& c, RowExecutor& exec) noexcept {
    Renderer::Impl& im = *c.im;
    if (im.useGl) {
        GlStatus st = GlStatus::kOk;
        for (std::size_t k = 0; k < im.glStale.size() && st == GlStatus::kOk; ++k) {
            if (!im.glStale[k]) continue;
            st = im.gl->setVertices(static_cast<int>(k),
                                    reinterpret_cast<const float*>(im.objects[k].vbuf));
            im.glStale[k] = st == GlStatus::kOk ? 0 : 1;
        }
        const PinholeCamera& pc = c.cfg->camera;
        GlView view;
        view.width = pc.width;
        view.height = pc.height;
        view.focalLength_m = pc.focalLength_m;
        view.pitchX_m = pc.pitchX_m;
        view.pitchY_m = pc.pitchY_m;
        view.position_m = im.camPos;
        view.forward = im.camFwd;
        view.right = im.camRight;
        view.up = im.camUp;
        if (st == GlStatus::kOk) {
            // The rows rowLo + rowStride·i lie in [rowLo, rowLo + rowStride (rowCount − 1)]; with
            // a stride of 2 the other field's rows in between are drawn too and not read.
            st = im.gl->render(view, c.colLo, c.rowLo, c.colHi,
                               c.rowLo + c.rowStride * (c.rowCount - 1) + 1);
        }
        if (st == GlStatus::kOk) {
            exec.run(c.rowCount, &glPrimaryRows, &c);
            return;
        }
        ++im.glFailures;
    }
    exec.run(c.rowCount, &primaryRows, &c);
}

// A context for a primary pass over the whole image (no shading).
Ctx fullPrimaryCtx(Renderer::Impl& im, const RenderConfig& cfg) noexcept {
    Ctx c{&im, &cfg, nullptr, {}, {}, 1, kTermAll, false, false, rowStep(im.H), 1};
    c.rowLo = 0;
    c.rowCount = im.H;
    c.rowStepRect = c.rowStepImage;
    c.colLo = 0;
    c.colHi = im.W;
    return c;
}

// Mean wall time of `reps` primary passes [ms] after one untimed pass (shader compilation,
// caches), with OpenGL (useGl) or Embree.
double timePrimaryPass(Renderer::Impl& im, const RenderConfig& cfg, bool useGl, RowExecutor& exec,
                       int reps) noexcept {
    const bool was = im.useGl;
    im.useGl = useGl;
    Ctx c = fullPrimaryCtx(im, cfg);
    primaryPass(c, exec);
    const auto t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < reps; ++r)
        primaryPass(c, exec);
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    im.useGl = was;
    im.gValidRows = 0;
    return 1e3 * dt / std::max(1, reps);
}

// PrimaryVisibility::kAuto: both passes timed on the current view with the frame loop's
// executor; the faster makes the G-buffer from now on (a GL pass that failed is not chosen).
void decideAuto(Renderer::Impl& im, const RenderConfig& cfg, RowExecutor& exec) noexcept {
    im.autoPending = false;
    if (!im.gl) return;
    constexpr int kReps = 3;
    const std::uint64_t failures = im.glFailures;
    im.autoEmbree_ms = timePrimaryPass(im, cfg, false, exec, kReps);
    im.autoGl_ms = timePrimaryPass(im, cfg, true, exec, kReps);
    im.useGl = im.glFailures == failures && im.autoGl_ms < im.autoEmbree_ms;
}

// Whether the segment o + t·d, 0 ≤ t ≤ tmax, meets the box [lo − pad, hi + pad] (slabs).
bool segmentMeetsBox(const Vec3& o, const Vec3& d, double tmax, const Vec3& lo, const Vec3& hi,
                     double pad) noexcept {
    double t0 = 0.0, t1 = tmax;
    const double oa[3] = {o.x, o.y, o.z}, da[3] = {d.x, d.y, d.z};
    const double la[3] = {lo.x - pad, lo.y - pad, lo.z - pad};
    const double ha[3] = {hi.x + pad, hi.y + pad, hi.z + pad};
    for (int a = 0; a < 3; ++a) {
        if (da[a] == 0.0) {
            if (oa[a] < la[a] || oa[a] > ha[a]) return false;
            continue;
        }
        double ta = (la[a] - oa[a]) / da[a], tb = (ha[a] - oa[a]) / da[a];
        if (ta > tb) std::swap(ta, tb);
        t0 = std::max(t0, ta);
        t1 = std::min(t1, tb);
        if (t0 > t1) return false;
    }
    return true;
}

// After objects moved (Impl::dirtyLo/Hi): the static data of a pixel is dropped (rebuilt when
// next shaded) if a ray it was made from can cross a box — a shadow ray toward a lamp it
// covers (box grown by the lamp's emitter radius: any point of the emitter), its mirror ray up
// to the mirror hit (or without end to the sky), or the mirror hit's shadow rays. The pixels
// whose primary rays were redone have already dropped theirs.
void invalidateStaticRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const std::size_t nl = im.lamps.size();
    const std::uint64_t need = im.staticNeed;
    const auto crosses = [&](const Vec3& o, const Vec3& d, double tmax, double pad) {
        for (int b = 0; b < im.nDirty; ++b)
            if (segmentMeetsBox(o, d, tmax, im.dirtyLo[b], im.dirtyHi[b], pad)) return true;
        return false;
    };
    const auto lampsCross = [&](const Vec3& p) {
        for (std::size_t l = 0; l < nl; ++l) {
            if (!((need >> l) & 1u)) continue;
            const LampData& ld = im.lamps[l];
            if (crosses(p, ld.position - p, 1.0, ld.radius_m + 1e-3)) return true;
        }
        return false;
    };
    for (int yr = y0; yr < y1; ++yr) {
        const int y = rowAt(yr, c.rowStepImage, im.H);
        for (int x = 0; x < im.W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            if (!im.sValid[i] || im.gMat[i] == kMiss) continue;
            const Vec3 p = g3(im.gPos, i);
            bool drop = lampsCross(p);
            const std::uint16_t sm = im.sqMat[i];
            if (!drop && sm != kNotSpecular) {
                const Vec3 n = g3(im.gNrm, i);
                const Vec3 dIn = im.pixelDir(x + 0.5, y + 0.5, c.cfg->camera);
                const Vec3 r = dIn - n * (2.0 * dot(dIn, n));
                const Vec3 o = p + n * kEps_m;
                if (sm == kMiss) {
                    drop = crosses(o, r, kInf, 1e-3);
                } else {
                    const Vec3 q = g3(im.sqPos, i);
                    drop = crosses(o, q - o, 1.0, 1e-3) || lampsCross(q);
                }
            }
            if (drop) im.sValid[i] = 0;
        }
    }
}

// Full-rate shading of the G-buffer, 16 pixels at a time.
void shadeRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    Counts n;
    for (int yr = y0; yr < y1; ++yr) {
        const int y = shadeRowAt(c, yr);
        float* pe = c.pe.row(y);
        float* bw = c.bw.row(y);
        std::size_t qi[kPacket];
        int qx[kPacket], nq = 0;
        for (int x = 0; x < im.W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            if (im.gMat[i] == kMiss) {
                skyPixel(c, i, x, pe, bw);
                continue;
            }
            qi[nq] = i;
            qx[nq++] = x;
            if (nq == kPacket) {
                flushFull(c, nq, qi, qx, pe, bw, n);
                nq = 0;
            }
        }
        if (nq > 0) flushFull(c, nq, qi, qx, pe, bw, n);
    }
    im.shadow += n.shadow;
    im.secondary += n.secondary;
}

// Coarse nodes: radiance without the sky term at every f-th pixel, 16 at a time.
void nodeRows(void* vctx, int j0, int j1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const int f = c.coarse;
    Counts n;
    for (int jr = j0; jr < j1; ++jr) {
        const int j = rowAt(jr, c.rowStepNodes, im.nodeH);
        const int y = std::min(j * f, im.H - 1);
        std::size_t qi[kPacket], qn[kPacket];
        int nq = 0;
        const auto flush = [&] {
            float out[kBands][kPacket];
            shadeBatch(c, nq, qi, false, out, n);
            for (int k = 0; k < nq; ++k) {
                im.nodeRad[qn[k] * kBands] = out[0][k];
                im.nodeRad[qn[k] * kBands + 1] = out[1][k];
            }
            nq = 0;
        };
        for (int k = 0; k < im.nodeW; ++k) {
            const int x = std::min(k * f, im.W - 1);
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            const std::size_t node = static_cast<std::size_t>(j) * im.nodeW + k;
            if (im.gMat[i] == kMiss) {
                im.nodeRad[node * kBands] = im.nodeRad[node * kBands + 1] = 0.0f;
                continue;
            }
            qi[nq] = i;
            qn[nq++] = node;
            if (nq == kPacket) flush();
        }
        if (nq > 0) flush();
    }
    im.shadow += n.shadow;
    im.secondary += n.secondary;
}

// Upsampling weights of row y (static: from the G-buffer only). A pixel takes the bilinear
// weights of the four nodes around it, restricted to nodes on its own surface (same object and
// material, normals within 18°, node within a plane tolerance of 2 cm + 0.2 % of the range),
// normalised; with none it is shaded at full rate.
void buildWeightsRow(const Ctx& c, int y) noexcept {
    Renderer::Impl& im = *c.im;
    const int f = c.coarse;
    const float invF = 1.0f / static_cast<float>(f);
    const float cx = static_cast<float>(im.camPos.x), cy = static_cast<float>(im.camPos.y),
                cz = static_cast<float>(im.camPos.z);
    const int j = y / f;
    const float fy = static_cast<float>(y - j * f) * invF;
    const int nyRow[2] = {std::min(j * f, im.H - 1), std::min((j + 1) * f, im.H - 1)};
    for (int x = 0, k = 0, xr = 0; x < im.W; ++x, ++xr) {
        if (xr == f) xr = 0, ++k;  // k = x / f, xr = x mod f
        const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
        float* w = &im.uW[4 * i];
        w[0] = w[1] = w[2] = w[3] = 0.0f;
        const int m = im.gMat[i];
        if (m == kMiss) {
            im.uKind[i] = kUpMiss;
            continue;
        }
        const float* pp = &im.gPos[3 * i];
        const float* pn = &im.gNrm[3 * i];
        const float dx = pp[0] - cx, dy = pp[1] - cy, dz = pp[2] - cz;
        const float planeTol = 0.02f + 2e-3f * std::sqrt(dx * dx + dy * dy + dz * dz);
        const float fx = static_cast<float>(xr) * invF;
        const std::int16_t obj = im.gObj[i];
        // All four tests without early exits (the loads stay in the image; branch-free code
        // keeps the pipeline full); invalid taps weigh 0, which adds nothing to the sum.
        float wsum = 0.0f;
        for (int t = 0; t < 4; ++t) {
            const int dj = t >> 1, dk = t & 1;
            const std::size_t q = static_cast<std::size_t>(nyRow[dj]) * im.W +
                                  static_cast<std::size_t>(std::min((k + dk) * f, im.W - 1));
            const float* qn = &im.gNrm[3 * q];
            const float* qp = &im.gPos[3 * q];
            const float cosN = qn[0] * pn[0] + qn[1] * pn[1] + qn[2] * pn[2];
            const float off =
                (qp[0] - pp[0]) * pn[0] + (qp[1] - pp[1]) * pn[1] + (qp[2] - pp[2]) * pn[2];
            const bool ok = (im.gMat[q] == m) & (im.gObj[q] == obj) & !(cosN < 0.95f) &
                            !(std::abs(off) > planeTol);
            w[t] = ok ? (dk ? fx : 1.0f - fx) * (dj ? fy : 1.0f - fy) + 1e-6f : 0.0f;
            wsum += w[t];
        }
        if (!(wsum > 0.0f)) {
            im.uKind[i] = kUpFull;
            continue;
        }
        const float inv = 1.0f / wsum;
        for (int t = 0; t < 4; ++t)
            w[t] *= inv;
        im.uKind[i] = kUpInterp;
    }
}

// Upsampling: each pixel's radiance from its nodes' (precomputed weights) plus its own sky
// term; pixels with no node on their surface are shaded at full rate (16 at a time).
void upsampleRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const int f = c.coarse;
    const std::size_t nw = static_cast<std::size_t>(im.nodeW);
    Counts n;
    for (int yr = y0; yr < y1; ++yr) {
        const int y = shadeRowAt(c, yr);
        if (c.buildWeights && y >= c.weightsLo && y < c.weightsHi) buildWeightsRow(c, y);
        float* pe = c.pe.row(y);
        float* bw = c.bw.row(y);
        const std::size_t nodeRow = static_cast<std::size_t>(y / f) * nw;
        std::size_t qi[kPacket];
        int qx[kPacket], nq = 0;
        for (int x = 0, k = 0, xr = 0; x < im.W; ++x, ++xr) {
            if (xr == f) xr = 0, ++k;  // k = x / f
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            const std::uint8_t kind = im.uKind[i];
            if (kind == kUpInterp) {
                const float* w = &im.uW[4 * i];
                const float* r0 = &im.nodeRad[(nodeRow + static_cast<std::size_t>(k)) * kBands];
                const float* r1 = r0 + nw * kBands;
                const std::size_t mb = std::size_t{im.gMat[i]} * kBands;
                const float svf = im.gSvf[i];
                pe[x] =
                    w[0] * r0[0] + w[1] * r0[2] + w[2] * r1[0] + w[3] * r1[2] + im.kSky[mb] * svf;
                bw[x] = w[0] * r0[1] + w[1] * r0[3] + w[2] * r1[1] + w[3] * r1[3] +
                        im.kSky[mb + 1] * svf;
            } else if (kind == kUpMiss) {
                skyPixel(c, i, x, pe, bw);
            } else {
                qi[nq] = i;
                qx[nq++] = x;
                if (nq == kPacket) {
                    flushFull(c, nq, qi, qx, pe, bw, n);
                    nq = 0;
                }
            }
        }
        if (nq > 0) flushFull(c, nq, qi, qx, pe, bw, n);
    }
    im.shadow += n.shadow;
    im.secondary += n.secondary;
}

}  // namespace

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
    const std::size_t nl = im.lamps.size(), nm = im.materials.size();
    // What the static data must cover: the lamps that are on (with the lamp term) and the
    // specular bounce. A lamp switched on that it does not cover rebuilds it; one switched off
    // only drops out of the per-frame sums.
    std::uint64_t need = 0;
    if (terms_ & kTermLamps) {
        for (std::size_t l = 0; l < nl; ++l)
            if (lampOn_[l]) need |= std::uint64_t{1} << l;
    }
    if (config_.specular && (terms_ & kTermSpecular)) need |= kSpecBit;
    if (need & ~im.staticNeed) {
        im.staticNeed = need;
        std::fill(im.sValid.begin(), im.sValid.end(), std::uint8_t{0});
    }
    // Lamps outside `need` weigh 0 in every sum (kLamp below): they are left out of the loops,
    // which adds nothing but +0 to any sum, the same bits.
    im.activeLamps = 0;
    for (std::size_t l = 0; l < nl; ++l)
        if ((need >> l) & 1u) im.activeLamp[im.activeLamps++] = static_cast<int>(l);
    // Per-frame coefficients.
    const bool moonOn = sky.moonUp && (terms_ & kTermMoon);
    const double skyOn = (terms_ & kTermSky) ? 1.0 : 0.0;
    const double specOn = (config_.specular && (terms_ & kTermSpecular)) ? 1.0 : 0.0;
    for (std::size_t m = 0; m < nm; ++m) {
        const double s = im.materials[m].specularity, diffuse = 1.0 - s;
        for (int b = 0; b < kBands; ++b) {
            const std::size_t k = m * kBands + static_cast<std::size_t>(b);
            im.kMoon[k] =
                moonOn ? static_cast<float>(diffuse * rhoMoon_[k] * sky.moonNormal[b] / kPi) : 0.0f;
            im.kSky[k] = static_cast<float>(skyOn * diffuse *
                                            (rhoMoon_[k] * sky.moonSkyHorizontal[b] +
                                             rhoNight_[k] * sky.nightSkyHorizontal[b]) /
                                            kPi);
            im.kSpec[k] = static_cast<float>(specOn * s * rhoMoon_[k]);
            for (std::size_t l = 0; l < nl; ++l) {
                const bool on = (need >> l) & 1u;
                im.kLamp[l * nm * kBands + k] =
                    on ? static_cast<float>(diffuse * im.lamps[l].coef[k]) : 0.0f;
            }
        }
    }
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
    // Sky in view: the frame's table on the atmosphere table's (view zenith, Δφ) nodes (sim/sky
    // computes it), or isotropic.
    for (int b = 0; b < kBands; ++b) {
        float* t = &im.skyTab[static_cast<std::size_t>(b) * kSkyZ * kSkyA];
        if (sky.hasSkyRadiance) {
            const float* src = &sky.skyRadiance[static_cast<std::size_t>(b) * msg::kSkyNodes];
            std::copy(src, src + msg::kSkyNodes, t);
        } else {
            const double l = (sky.moonSkyHorizontal[b] + sky.nightSkyHorizontal[b]) / kPi;
            std::fill(t, t + kSkyZ * kSkyA, static_cast<float>(l));
        }
    }
    c.moonAz_rad = static_cast<float>(sky.moonAz_rad);
    c.moonDir[0] = static_cast<float>(sky.moonDir_enu.x);
    c.moonDir[1] = static_cast<float>(sky.moonDir_enu.y);
    c.moonDir[2] = static_cast<float>(sky.moonDir_enu.z);
    if (sky.moonUp) {
        const double omega = kPi * sky.moonAngularRadius_rad * sky.moonAngularRadius_rad;
        c.cosMoonRadius = static_cast<float>(std::cos(sky.moonAngularRadius_rad));
        for (int b = 0; b < kBands; ++b)
            c.moonDisk[b] = static_cast<float>(sky.moonNormal[b] / omega);
    }
    // The primary rays depend only on the camera and the geometry: with neither changed since
    // the last frame (a fixed camera over a static scene), the G-buffer is reused. A field
    // (rowParity ≥ 0, full-rate lighting) needs only its own rows; the others keep what the
    // last render of their parity left in the images.
    const int parity = rowParity >= 0 && coarse_ == 1 ? (rowParity & 1) : -1;
    const unsigned want = parity < 0 ? 3u : 1u << parity;
    unsigned missing = want & ~im.gValidRows;
    if (missing != 0 && im.nDirty > 0) {
        im.gValidRows = 0;  // objects moved: rows not cast again now are stale
        missing = want;
    }
    c.weightsLo = 0;
    c.weightsHi = im.H;
    if (missing != 0) {
        const int p = missing == 3u ? -1 : (missing == 2u ? 1 : 0);
        c.rowLo = p < 0 ? 0 : p;
        c.rowStride = p < 0 ? 1 : 2;
        c.rowCount = p < 0 ? im.H : (im.H - p + 1) / 2;
        c.rowStepRect = rowStep(c.rowCount);
        c.colLo = 0;
        c.colHi = im.W;
        primaryPass(c, exec);
        im.gValidRows |= missing;
        im.uFactor = 0;
        c.buildWeights = coarse_ > 1;
    } else if (im.nDirty > 0) {
        // Objects moved under a fixed camera: the primary rays of the pixels their boxes cover
        // on screen (a pixel's ray through its centre meets a box only inside the box's
        // projected corners' bounds; a box partly behind the camera covers the image).
        const PinholeCamera& pc = config_.camera;
        double u0 = kInf, u1 = -kInf, v0 = kInf, v1 = -kInf;
        bool all = false;
        for (int b = 0; b < im.nDirty && !all; ++b) {
            for (int k = 0; k < 8; ++k) {
                const Vec3 q{(k & 1) ? im.dirtyHi[b].x : im.dirtyLo[b].x,
                             (k & 2) ? im.dirtyHi[b].y : im.dirtyLo[b].y,
                             (k & 4) ? im.dirtyHi[b].z : im.dirtyLo[b].z};
                double u, v;
                if (!im.project(q, pc, &u, &v)) {
                    all = true;
                    break;
                }
                u0 = std::min(u0, u);
                u1 = std::max(u1, u);
                v0 = std::min(v0, v);
                v1 = std::max(v1, v);
            }
        }
        const int x0 = all ? 0 : std::clamp(static_cast<int>(std::floor(u0)) - 1, 0, im.W);
        const int x1 = all ? im.W : std::clamp(static_cast<int>(std::ceil(u1)) + 1, 0, im.W);
        const int y0 = all ? 0 : std::clamp(static_cast<int>(std::floor(v0)) - 1, 0, im.H);
        const int y1 = all ? im.H : std::clamp(static_cast<int>(std::ceil(v1)) + 1, 0, im.H);
        if (x1 > x0 && y1 > y0) {
            c.rowLo = y0;
            c.rowCount = y1 - y0;
            c.rowStepRect = rowStep(c.rowCount);
            c.colLo = x0;
            c.colHi = x1;
            primaryPass(c, exec);
        }
        // Static data made from rays that may cross a box.
        if (im.staticNeed != 0) exec.run(im.H, &invalidateStaticRows, &c);
        // Upsampling weights read the G-buffer up to one node spacing away.
        if (coarse_ > 1 && !c.buildWeights && x1 > x0 && y1 > y0) {
            c.buildWeights = true;
            c.weightsLo = std::max(0, y0 - coarse_);
            c.weightsHi = std::min(im.H, y1 + coarse_);
        }
    }
    im.nDirty = 0;
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
    // Sources in view land on one pixel each, drawn only in the rows this render fills.
    const auto ownRow = [parity](int py) { return parity < 0 || (py & 1) == parity; };
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
        const int px = static_cast<int>(u), py = static_cast<int>(v);
        if (!ownRow(py)) continue;
        if (im.occluded(im.camPos, dn, static_cast<float>(r - ld.radius_m - 1e-3))) continue;
        const double toPixel = intensityScale / (r * r) / omegaPixel;
        pe(px, py) += static_cast<float>(ld.emitted[kBandPe] * toPixel);
        bandW(px, py) += static_cast<float>(ld.emitted[kBandW] * toPixel);
    }
    // Stars in view: the irradiance each gives at the lens, spread over the pixel it falls in
    // (E / Ω_pixel), if it is above the horizon and no geometry is in the way.
    for (int k = 0; k < sky.starCount && (terms_ & kTermInView); ++k) {
        const FrameStar& st = sky.stars[static_cast<std::size_t>(k)];
        if (!(st.dir_enu.z > 0.0)) continue;
        double u, v;
        if (!im.project(im.camPos + st.dir_enu, cam, &u, &v)) continue;
        if (u < 0 || v < 0 || u >= cam.width || v >= cam.height) continue;
        const int px = static_cast<int>(u), py = static_cast<int>(v);
        if (!ownRow(py)) continue;
        if (im.occluded(im.camPos, st.dir_enu, kInf)) continue;
        pe(px, py) += static_cast<float>(st.irradiance[kBandPe] / omegaPixel);
        bandW(px, py) += static_cast<float>(st.irradiance[kBandW] / omegaPixel);
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
                alignas(64) int valid[kPacket];  // Embree: a packet's valid mask is 64-byte aligned
                RTCRayHit16 rh;
                initHits(rh);
                clearPacket(rh.ray, valid);
                for (int k = 0; k < kPacket; ++k) {
                    const int x = x0 + k % kTileW, y = y0 + k / kTileW;
                    if (x >= im.W || y >= im.H) continue;
                    valid[k] = -1;
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
    if (im.gl) im.gl->setEnabled(object, enabled);
    im.gValidRows = 0;
}

bool Renderer::pixelSurface(int x, int y, Vec3* normal, double* skyViewFactor) const noexcept {
    const Impl& im = *impl_;
    const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
    if (im.gMat[i] == kMiss) return false;
    *normal = g3(im.gNrm, i);
    *skyViewFactor = im.gSvf[i];
    return true;
}

const char* primaryVisibilityName(PrimaryVisibility v) noexcept {
    switch (v) {
        case PrimaryVisibility::kGl:
            return "gl";
        case PrimaryVisibility::kAuto:
            return "auto";
        case PrimaryVisibility::kEmbree:
            break;
    }
    return "embree";
}

bool parsePrimaryVisibility(const std::string& s, PrimaryVisibility* v) noexcept {
    for (PrimaryVisibility p :
         {PrimaryVisibility::kEmbree, PrimaryVisibility::kGl, PrimaryVisibility::kAuto}) {
        if (s == primaryVisibilityName(p)) {
            *v = p;
            return true;
        }
    }
    return false;
}

bool Renderer::primaryByGl() const noexcept {
    return impl_->useGl;
}

std::string Renderer::choosePrimaryVisibility(RowExecutor& exec) {
    if (impl_->autoPending) decideAuto(*impl_, config_, exec);
    if (impl_->gl) impl_->gl->releaseContext();  // the frame loop's thread renders next
    return primaryVisibilityNote();
}

std::string Renderer::primaryVisibilityNote() const {
    const Impl& im = *impl_;
    const PrimaryVisibility asked = config_.primaryVisibility;
    std::string s = std::string("primary visibility ") + (im.useGl ? "gl" : "embree") + " (" +
                    primaryVisibilityName(asked);
    if (im.gl) {
        s += std::string(", OpenGL ") + glBackendName(im.gl->backend()) + ": " +
             im.gl->description();
    } else if (asked != PrimaryVisibility::kEmbree) {
        s += ", no OpenGL: " + im.glReason;
    }
    if (im.autoGl_ms >= 0.0) {
        char b[96];
        std::snprintf(b, sizeof b, "; first view: gl %.2f ms, embree %.2f ms", im.autoGl_ms,
                      im.autoEmbree_ms);
        s += b;
    } else if (im.autoPending) {
        s += "; chosen at the first render";
    }
    return s + ")";
}

Renderer::PrimaryTiming Renderer::measurePrimaryPasses(RowExecutor& exec, int repetitions) {
    Impl& im = *impl_;
    PrimaryTiming t;
    t.embree_ms = timePrimaryPass(im, config_, false, exec, repetitions);
    if (im.gl) {
        const std::uint64_t failures = im.glFailures;
        const double ms = timePrimaryPass(im, config_, true, exec, repetitions);
        if (im.glFailures == failures) t.gl_ms = ms;
        im.gl->releaseContext();
    }
    return t;
}

}  // namespace nvs::render
