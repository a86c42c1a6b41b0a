// The renderer's primary visibility: the G-buffer (each pixel's primary hit: position, normal,
// material, object, sky-view factor) from Embree's coherent packets or from the OpenGL pass
// (gl_visibility.h), the automatic choice between the two, and what objects that moved under a
// fixed camera invalidate (their pixels' primary rays, the static data whose rays cross them).

#include <chrono>
#include <cstdio>
#include <cstring>

#include "sim/render/render_impl.h"

namespace nvs::render {
namespace detail {
namespace {

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

// One triangle seen from the camera, set up once for the pixels that see it (neighbouring
// pixels mostly do): its unit normal N̂ = (v1 − v0) × (v2 − v0) / |…|, the numerator of the
// plane distance N̂·(v0 − o), and the dual vectors U = (e2 × N)/|N|², V = (N × e1)/|N|² that
// give a point r = p − v0 of the plane its barycentric weights u = r·U (of v1), v = r·V (of v2),
// with e1 = v1 − v0, e2 = v2 − v0, N = e1 × e2. Per pixel: t = N̂·(v0 − o) / N̂·d, p = o + t d.
struct SeenTriangle {
    std::uint32_t geom = kGlMiss, prim = kGlMiss;
    bool ok = false;  // not degenerate
    Vec3 v0, nUnit, dualU, dualV;
    double planeNum = 0.0;
    void set(std::uint32_t g, std::uint32_t p, const Vec3& a, const Vec3& b, const Vec3& c,
             const Vec3& o) noexcept {
        geom = g;
        prim = p;
        v0 = a;
        const Vec3 e1 = b - a, e2 = c - a, n = cross(e1, e2);
        const double n2 = dot(n, n);
        ok = n2 > 0.0;
        if (!ok) return;
        nUnit = n * (1.0 / std::sqrt(n2));
        dualU = cross(e2, n) * (1.0 / n2);
        dualV = cross(n, e1) * (1.0 / n2);
        planeNum = dot(nUnit, a - o);
    }
};

// The G-buffer of the pass's rectangle from the OpenGL pass's hits (gl_visibility.h): the same
// fields as primaryRows, through hitFieldsUnit, from the triangle GL found at each pixel and
// the point where the pixel-centre ray meets its plane, in double (SeenTriangle). The geometric
// normal is Embree's for the triangle, Ng = e2 × e1 with e1 = v0 − v1, e2 = v2 − v0, that is
// (v1 − v0) × (v2 − v0) (Embree 3, kernels/geometry/triangle_intersector_moeller.h), so a hit's
// side, and with it the side's sky-view factors, is the one Embree's hit gives (the test
// GlPrimary.* compares them).
void glPrimaryRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    const PinholeCamera& cam = c.cfg->camera;
    const std::uint32_t* ids = im.gl->ids();
    GlVisibility::IdRange mesh;  // the last pixel's
    SeenTriangle seen;           // the last hit's
    const Vec3 o = im.camPos;
    for (int yr = y0; yr < y1; ++yr) {
        const int y = c.rowLo + c.rowStride * rowAt(yr, c.rowStepRect, c.rowCount);
        for (int x = c.colLo; x < c.colHi; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            im.sValid[i] = 0;
            const Vec3 d = im.pixelDir(x + 0.5, y + 0.5, cam);
            if (ids[i] - 1u - mesh.firstId >= mesh.count) mesh = im.gl->idRange(ids[i]);
            const std::uint32_t geom = mesh.geomId, prim = ids[i] - 1u - mesh.firstId;
            const bool hit = mesh.count != 0 && geom < im.objects.size() &&
                             prim < im.objects[geom].material.size();
            if (hit && (geom != seen.geom || prim != seen.prim)) {
                const ObjectData& od = im.objects[geom];
                const std::uint32_t* tri =
                    &od.obj->mesh.triangles[3 * static_cast<std::size_t>(prim)];
                seen.set(geom, prim, toV(od.vbuf[tri[0]]), toV(od.vbuf[tri[1]]),
                         toV(od.vbuf[tri[2]]), o);
            }
            const double nd = hit && seen.ok ? dot(seen.nUnit, d) : 0.0;
            if (nd == 0.0) {
                double gz, az;
                skyGridPos(d, &gz, &az);
                im.gMat[i] = kMiss;
                im.gObj[i] = -1;
                put3(im.gPos, i, d);
                put3(im.gNrm, i, Vec3{gz, az, 0.0});
                continue;
            }
            const Vec3 p = o + d * (seen.planeNum / nd), r = p - seen.v0;
            Vec3 n;
            int m;
            double svf;
            hitFieldsUnit(im, geom, prim, dot(r, seen.dualU), dot(r, seen.dualV), seen.nUnit, d, &n,
                          &m, &svf);
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
        const GlView view{pc.width,  pc.height, pc.focalLength_m, pc.pitchX_m, pc.pitchY_m,
                          im.camPos, im.camFwd, im.camRight,      im.camUp};
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
}  // namespace

double timePrimaryPass(Renderer::Impl& im, const RenderConfig& cfg, bool useGl, RowExecutor& exec,
                       int reps, double* glRender_ms) noexcept {
    const bool was = im.useGl;
    im.useGl = useGl;
    Ctx c = fullPrimaryCtx(im, cfg);
    primaryPass(c, exec);
    double glSum_ms = reps == 0 && useGl && im.gl ? im.gl->lastRender_ms() : 0.0;
    const auto t0 = std::chrono::steady_clock::now();
    for (int r = 0; r < reps; ++r) {
        primaryPass(c, exec);
        if (useGl && im.gl) glSum_ms += im.gl->lastRender_ms();
    }
    const double dt = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
    if (glRender_ms != nullptr) *glRender_ms = glSum_ms / std::max(1, reps);
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

namespace {

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

// Primary rays of the rows in `missing` (bit 0 the even rows, bit 1 the odd ones).
void castRows(Ctx& c, unsigned missing, RowExecutor& exec) noexcept {
    ++c.im->gGeneration;
    Renderer::Impl& im = *c.im;
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
    c.buildWeights = c.coarse > 1;
}

// Objects moved under a fixed camera: the primary rays of the pixels their boxes cover on screen
// and the static data whose rays may cross a box.
void redoMovedObjects(Ctx& c, RowExecutor& exec) noexcept {
    ++c.im->gGeneration;
    Renderer::Impl& im = *c.im;
    // Objects moved under a fixed camera: the primary rays of the pixels their boxes cover
    // on screen (a pixel's ray through its centre meets a box only inside the box's
    // projected corners' bounds; a box partly behind the camera covers the image).
    const PinholeCamera& pc = c.cfg->camera;
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
    if (c.coarse > 1 && !c.buildWeights && x1 > x0 && y1 > y0) {
        c.buildWeights = true;
        c.weightsLo = std::max(0, y0 - c.coarse);
        c.weightsHi = std::min(im.H, y1 + c.coarse);
    }
}

}  // namespace

// The primary rays depend only on the camera and the geometry: with neither changed since the
// last frame (a fixed camera over a static scene), the G-buffer is reused. A field (parity ≥ 0,
// full-rate lighting) needs only its own rows; the others keep what the last render of their
// parity left in the images.
void updateGeometryBuffer(Ctx& c, int parity, RowExecutor& exec) noexcept {
    Renderer::Impl& im = *c.im;
    const unsigned want = parity < 0 ? 3u : 1u << parity;
    unsigned missing = want & ~im.gValidRows;
    if (missing != 0 && im.nDirty > 0) {
        im.gValidRows = 0;  // objects moved: rows not cast again now are stale
        missing = want;
    }
    c.weightsLo = 0;
    c.weightsHi = im.H;
    if (missing != 0) {
        castRows(c, missing, exec);
    } else if (im.nDirty > 0) {
        redoMovedObjects(c, exec);
    }
    im.nDirty = 0;
}

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

}  // namespace detail

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

Renderer::PrimaryTiming Renderer::measurePrimaryPasses(RowExecutor& exec, int repetitions,
                                                       PrimaryPaths paths) {
    Impl& im = *impl_;
    PrimaryTiming t;
    if (paths != PrimaryPaths::kGl) {
        t.embree_ms = timePrimaryPass(im, config_, false, exec, repetitions);
    }
    if (im.gl && paths != PrimaryPaths::kEmbree) {
        const std::uint64_t failures = im.glFailures;
        double render_ms = 0.0;
        const double ms = timePrimaryPass(im, config_, true, exec, repetitions, &render_ms);
        if (im.glFailures == failures) {
            t.gl_ms = ms;
            t.glRender_ms = render_ms;
        }
        im.gl->releaseContext();
    }
    return t;
}

}  // namespace nvs::render
