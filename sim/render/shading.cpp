// The renderer's shading: lamp and Moon factors through packets of shadow rays, the static data
// of a pixel (lamp factors, the mirror ray's hit), the radiance of a batch of hit pixels and the
// full-rate pass over the image.
//
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

#include "sim/render/render_impl.h"

namespace nvs::render::detail {
namespace {

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

}  // namespace

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

// Full-rate shading of the G-buffer, 16 pixels at a time.
void shadeRows(void* vctx, int y0, int y1) {
    const Ctx& c = *static_cast<const Ctx*>(vctx);
    Renderer::Impl& im = *c.im;
    Counts n;
    for (int yr = y0; yr < y1; ++yr) {
        const int y = shadeRowAt(c, yr);
        float* pe = c.pe.row(y);
        float* bw = c.bw.row(y);
        ShadeQueue q;
        for (int x = 0; x < im.W; ++x) {
            const std::size_t i = static_cast<std::size_t>(y) * im.W + x;
            if (im.gMat[i] == kMiss) {
                skyPixel(c, i, x, pe, bw);
                continue;
            }
            q.push(c, i, x, pe, bw, n);
        }
        q.finish(c, pe, bw, n);
    }
    im.shadow += n.shadow;
    im.secondary += n.secondary;
}

}  // namespace nvs::render::detail
