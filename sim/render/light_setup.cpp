// The renderer's light set-up: at setup, the (source, material) band coefficients, the lamps
// (aperture samples, coefficients, what the camera sees of them) and the sky-view factors; per
// frame, the coefficients of the sums (docs/render.md) and the sky in view.

#include "sim/render/render_impl.h"

namespace nvs::render::detail {

// Source-material coefficients: ρ_src,m,b = ∫S ρ w / ∫S w.
void sourceMaterialCoefficients(const scene::Scene& sc, const RenderConfig& config,
                                std::vector<double>* rhoMoon, std::vector<double>* rhoNight) {
    const std::size_t nm = sc.materials.size();
    rhoMoon->assign(nm * kBands, 0.0);
    rhoNight->assign(nm * kBands, 0.0);
    for (std::size_t m = 0; m < nm; ++m) {
        for (int b = 0; b < kBands; ++b) {
            const Spectrum& w = config.bandWeight[static_cast<std::size_t>(b)];
            const Spectrum mw = config.moonShape * w;
            const Spectrum nw = config.nightSkyShape * w;
            const double md = mw.integrate_nm(), nd = nw.integrate_nm();
            (*rhoMoon)[m * kBands + static_cast<std::size_t>(b)] =
                md > 0 ? integrateProduct_nm(mw, sc.materials[m].reflectance) / md : 0.0;
            (*rhoNight)[m * kBands + static_cast<std::size_t>(b)] =
                nd > 0 ? integrateProduct_nm(nw, sc.materials[m].reflectance) / nd : 0.0;
        }
    }
}

// Lamps: the emitter's samples (Vogel spiral over an aperture), its band values and the
// coefficients ∫ S ρ_m w_b dλ / π.
void setUpLamps(Renderer::Impl& im, const scene::Scene& sc, const RenderConfig& config) {
    const std::size_t nm = sc.materials.size();
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
                ld.coef[m * kBands + static_cast<std::size_t>(b)] =
                    integrateProduct_nm(sw, sc.materials[m].reflectance) / kPi;
            }
        }
        if (l.attachObject >= 0) {
            ld.attach = l.attachObject;
            ld.local = l;
        }
        im.lamps.push_back(std::move(ld));
    }
    placeAttachedLamps(im);
}

void placeAttachedLamps(Renderer::Impl& im) noexcept {
    bool moved = false;
    for (LampData& ld : im.lamps) {
        if (ld.attach < 0) continue;
        Vec3 p, a;
        ld.local.placeAt(im.objects[static_cast<std::size_t>(ld.attach)].obj, im.time_s, &p, &a);
        if (p == ld.position && a == ld.axis) continue;
        ld.position = p;
        ld.axis = a;
        moved = true;
    }
    if (moved) std::fill(im.sValid.begin(), im.sValid.end(), std::uint8_t{0});
}

// Sky-view factors: cosine-weighted hemisphere rays from points near each triangle corner, for
// both sides (F = fraction of cosine-weighted directions that reach the sky; rays below the
// horizon count as ground).
void computeSkyViewFactors(Renderer::Impl& im, const RenderConfig& config) {
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
}

void frameCoefficients(Renderer::Impl& im, const RenderConfig& config, const FrameSky& sky,
                       unsigned terms, const std::vector<bool>& lampOn,
                       const std::vector<double>& rhoMoon,
                       const std::vector<double>& rhoNight) noexcept {
    const std::size_t nl = im.lamps.size(), nm = im.materials.size();
    // What the static data must cover: the lamps that are on (with the lamp term) and the
    // specular bounce. A lamp switched on that it does not cover rebuilds it; one switched off
    // only drops out of the per-frame sums.
    std::uint64_t need = 0;
    if (terms & kTermLamps) {
        for (std::size_t l = 0; l < nl; ++l)
            if (lampOn[l]) need |= std::uint64_t{1} << l;
    }
    if (config.specular && (terms & kTermSpecular)) need |= kSpecBit;
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
    const bool moonOn = sky.moonUp && (terms & kTermMoon);
    const double skyOn = (terms & kTermSky) ? 1.0 : 0.0;
    const double specOn = (config.specular && (terms & kTermSpecular)) ? 1.0 : 0.0;
    for (std::size_t m = 0; m < nm; ++m) {
        const double s = im.materials[m].specularity, diffuse = 1.0 - s;
        for (int b = 0; b < kBands; ++b) {
            const std::size_t k = m * kBands + static_cast<std::size_t>(b);
            im.kMoon[k] =
                moonOn ? static_cast<float>(diffuse * rhoMoon[k] * sky.moonNormal[b] / kPi) : 0.0f;
            im.kSky[k] = static_cast<float>(
                skyOn * diffuse *
                (rhoMoon[k] * sky.moonSkyHorizontal[b] + rhoNight[k] * sky.nightSkyHorizontal[b]) /
                kPi);
            im.kSpec[k] = static_cast<float>(specOn * s * rhoMoon[k]);
            for (std::size_t l = 0; l < nl; ++l) {
                const bool on = (need >> l) & 1u;
                im.kLamp[l * nm * kBands + k] =
                    on ? static_cast<float>(diffuse * im.lamps[l].coef[k]) : 0.0f;
            }
        }
    }
}

void frameSkyInView(Renderer::Impl& im, const FrameSky& sky, Ctx& c) noexcept {
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
}

}  // namespace nvs::render::detail
