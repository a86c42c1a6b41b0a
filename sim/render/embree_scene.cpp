// The renderer's Embree scene: the device (its kernel set), the scene and one triangle geometry
// per object; the objects' placement at a time (moving objects, with the boxes they sweep); an
// object taken out or put back; and one plain pass of primary rays for the benchmarks.

#include "sim/core/cpu_isa.h"
#include "sim/render/render_impl.h"

namespace nvs::render {
namespace detail {

// Embree's device with its kernel set, the scene (its BVH quality) and the objects' geometries.
void createEmbreeScene(Renderer::Impl& im, const scene::Scene& sc, const RenderConfig& config) {
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
}

}  // namespace detail

void Renderer::setTime(double t_s) noexcept {
    Impl& im = *impl_;
    im.time_s = t_s;
    placeAttachedLamps(im);
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

std::uint64_t Renderer::tracePrimaryRays(bool packets) const noexcept {
    const Impl& im = *impl_;
    const PinholeCamera& cam = config_.camera;
    std::uint64_t hits = 0;
    if (!packets) {
        for (int y = 0; y < im.H; ++y) {
            for (int x = 0; x < im.W; ++x) {
                RTCRayHit rh;
                hits += im.intersect(im.camPos, im.pixelDir(x + 0.5, y + 0.5, cam), &rh) ? 1u : 0u;
            }
        }
        return hits;
    }
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
    return hits;
}

}  // namespace nvs::render
