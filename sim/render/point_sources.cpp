// The renderer's point sources: lamps and stars in view, each drawn on the one pixel it falls in
// with the pixel-mean radiance of a source smaller than a pixel, if no geometry is in the way.

#include "sim/render/render_impl.h"

namespace nvs::render::detail {

// Sources in view land on one pixel each, drawn only in the rows this render fills.
void drawPointSources(const Renderer::Impl& im, const RenderConfig& config, const FrameSky& sky,
                      const std::vector<bool>& lampOn, unsigned terms, int parity,
                      ImageView<float> pe, ImageView<float> bandW) noexcept {
    const auto ownRow = [parity](int py) { return parity < 0 || (py & 1) == parity; };
    // Lamps in view: each lamp's light reaching the lens, spread over the pixel it falls in
    // (I / r² / Ω_pixel: the pixel-mean radiance of a source smaller than a pixel).
    const PinholeCamera& cam = config.camera;
    const double omegaPixel = cam.pitchX_m * cam.pitchY_m / (cam.focalLength_m * cam.focalLength_m);
    for (std::size_t l = 0; l < im.lamps.size() && (terms & kTermInView); ++l) {
        if (!lampOn[l]) continue;
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
    for (int k = 0; k < sky.starCount && (terms & kTermInView); ++k) {
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
}

}  // namespace nvs::render::detail
