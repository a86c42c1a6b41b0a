// Bright stars in view. (1) On the RIT roof at the thesis's nolight time, the camera is aimed
// at the brightest high star, placed here by textbook formulas (Meeus, Astronomical Algorithms:
// GMST eq. 12.4, low-precision precession eq. 21.1, horizontal coordinates eq. 13.5–13.6,
// Sæmundsson refraction eq. 16.4) rather than ERFA; its pixel must hold the photoelectron flux
// E_v(V) · ∫B w_pe / (K_m ∫B V) · T_direct(z), with the band integrals summed here on the 1 nm
// grid. (2) With a hand-made sky: a star's flux lands whole in one pixel, and nothing is drawn
// for a star behind geometry or below the horizon. (3) The frame's star list holds only stars
// above the horizon.

#include <gtest/gtest.h>

#include <array>
#include <cmath>

#include "rt/compose/scene_setup.h"
#include "sim/astro/time.h"
#include "sim/core/photometry.h"
#include "sim/core/planck.h"
#include "sim/render/renderer.h"
#include "sim/sky/stars.h"
#include "tests/sim/core/test_paths.h"
#include "tests/sim/render/embree_pin.h"

namespace nvs::render {
using rt::renderConfigFor;
using rt::ScenarioRenderer;
using sky::loadStarCatalog;
using sky::StarCatalog;
using sky::starCatalogPath;
namespace {

// V(λ) from the source tree's config/ (loaded once for this file's tests).
const Photometry& photometry() {
    static const Photometry p(test::configDir());
    return p;
}

constexpr double kPi = 3.14159265358979323846;
constexpr double kDeg = kPi / 180.0;

// Apparent azimuth/altitude [rad] of a J2000 star at UT1 Julian date jd from a site.
void textbookAzAlt(double ra_rad, double dec_rad, double jd, double lat_deg, double lon_deg,
                   double* az, double* alt) {
    const double d = jd - 2451545.0, t = d / 36525.0, years = d / 365.25;
    // Precession to the date (Meeus eq. 21.1): m = 3.075 s, n = 1.336 s = 20.04″ per year.
    const double dra_s = (3.075 + 1.336 * std::sin(ra_rad) * std::tan(dec_rad)) * years;
    const double ddec_as = 20.04 * std::cos(ra_rad) * years;
    const double ra = ra_rad + dra_s * 15.0 / 3600.0 * kDeg;
    const double dec = dec_rad + ddec_as / 3600.0 * kDeg;
    const double gmst_deg = 280.46061837 + 360.98564736629 * d + 0.000387933 * t * t;
    const double h = (gmst_deg + lon_deg) * kDeg - ra;
    const double phi = lat_deg * kDeg;
    const double sinAlt =
        std::sin(phi) * std::sin(dec) + std::cos(phi) * std::cos(dec) * std::cos(h);
    const double a = std::asin(sinAlt);
    *az = std::atan2(-std::cos(dec) * std::sin(h),
                     std::sin(dec) * std::cos(phi) - std::cos(dec) * std::cos(h) * std::sin(phi));
    // Refraction at 1013.25 hPa, 15 °C (the site's defaults), Sæmundsson scaled by P/1010·283/T.
    const double a_deg = a / kDeg;
    const double r_arcmin = 1.02 / std::tan((a_deg + 10.3 / (a_deg + 5.11)) * kDeg);
    *alt = a + r_arcmin / 60.0 * kDeg * (1013.25 / 1010.0) * (283.0 / 288.15);
}

// ∫B_T w dλ / (K_m ∫B_T V dλ), summed on the 1 nm grid.
double perLux(const Spectrum& w, double temperature_K) {
    double bw = 0.0, bv = 0.0;
    for (int i = 0; i < SpectralGrid::kCount; ++i) {
        const double b =
            planckSpectralRadiance_W_m2_sr_nm(SpectralGrid::wavelength_nm(i), temperature_K);
        bw += b * w[i];
        bv += b * photometry().photopicV()[i];
    }
    return bw / (683.0 * bv);
}

TEST(StarsInView, BrightStarGivesItsPhotoelectronFluxInItsPixel) {
    auto sr = ScenarioRenderer::create(test::sourceDir() / "scenarios/rit/nolight.toml",
                                       test::dataDirs());
    Renderer& r = sr->renderer();
    const FrameSky sky = sr->prepare(0.0);
    const StarCatalog cat = loadStarCatalog(starCatalogPath(test::configDir()));
    const auto& site = sr->scenario().scene.site;
    const astro::AstroTime t0 =
        astro::astroTimeFromUtc(astro::parseIsoUtc(sr->scenario().utcStart));
    const double jd = t0.ut1Jd1 + t0.ut1Jd2;
    // The highest star brighter than V = 1 (its line of sight clears the roof's geometry).
    int best = -1;
    double bestAz = 0, bestAlt = -1;
    for (std::size_t i = 0; i < cat.size(); ++i) {
        double az, alt;
        textbookAzAlt(cat.ra_rad[i], cat.dec_rad[i], jd, site.lat_deg, site.lon_deg, &az, &alt);
        if (cat.vMag[i] < 1.0 && alt > bestAlt)
            best = static_cast<int>(i), bestAz = az, bestAlt = alt;
    }
    ASSERT_GE(best, 0);
    ASSERT_GT(bestAlt, 30 * kDeg);
    const Vec3 dir = enuFromAzAlt(bestAz, bestAlt);
    scene::CameraPose pose = sr->scene().camera;
    pose.target_m = pose.position_m + dir * 10.0;
    pose.up = {0.0, 1.0, 0.0};
    pose.twist_rad = 0.0;
    r.setCamera(pose);
    r.setTerms(kTermInView);
    const PinholeCamera& cam = r.camera();
    ImageF pe(cam.width, cam.height), w(cam.width, cam.height);
    SerialExecutor ex;
    r.render(sky, pe.view(), w.view(), ex);
    // The brightest pixel within 10 px of the centre, less the sky around it.
    const int cx = cam.width / 2, cy = cam.height / 2;
    int bx = cx, by = cy;
    for (int y = cy - 10; y <= cy + 10; ++y)
        for (int x = cx - 10; x <= cx + 10; ++x)
            if (pe(x, y) > pe(bx, by)) bx = x, by = y;
    const double background = 0.25 * static_cast<double>(pe(bx - 3, by) + pe(bx + 3, by) +
                                                         pe(bx, by - 3) + pe(bx, by + 3));
    const double omegaPixel = cam.pitchX_m * cam.pitchY_m / (cam.focalLength_m * cam.focalLength_m);
    const double got = (static_cast<double>(pe(bx, by)) - background) * omegaPixel;
    const RenderConfig cfg = renderConfigFor(sr->camera(), cam.width, cam.height);
    const double transmittance =
        sr->sky().table().directTransmittance(sr->tableBands()[kBandPe], kPi / 2 - bestAlt);
    const double want = std::pow(10.0, -0.4 * (cat.vMag[static_cast<std::size_t>(best)] + 13.99)) *
                        perLux(cfg.bandWeight[kBandPe], 5800.0) * transmittance;
    std::printf(
        "%s: az %.2f alt %.2f deg (textbook), pixel (%d, %d) vs centre (%d, %d); "
        "%.4e pe/s/m2 at the lens (expected %.4e, %+.2f %%); T = %.3f\n",
        cat.name[static_cast<std::size_t>(best)].c_str(), bestAz / kDeg, bestAlt / kDeg, bx, by, cx,
        cy, got, want, 100 * (got / want - 1), transmittance);
    EXPECT_LE(std::abs(bx - cx), 3);
    EXPECT_LE(std::abs(by - cy), 3);
    EXPECT_NEAR(got / want, 1.0, 0.03);
    EXPECT_GT(got, 1e3 * background * omegaPixel);
}

TEST(StarsInView, FrameListsOnlyStarsAboveTheHorizon) {
    auto sr = ScenarioRenderer::create(test::sourceDir() / "scenarios/rit/nolight.toml",
                                       test::dataDirs());
    const StarCatalog cat = loadStarCatalog(starCatalogPath(test::configDir()));
    for (double t_s : {0.0, 6 * 3600.0, 12 * 3600.0}) {
        const FrameSky sky = sr->prepare(t_s);
        EXPECT_GT(sky.starCount, 5);
        EXPECT_LT(sky.starCount, static_cast<int>(cat.size()));
        for (int k = 0; k < sky.starCount; ++k) {
            EXPECT_GT(sky.stars[static_cast<std::size_t>(k)].dir_enu.z, 0.0);
            EXPECT_GT(sky.stars[static_cast<std::size_t>(k)].irradiance[kBandPe], 0.0);
        }
    }
}

// sim/sky's frameStars alone: a star below the horizon is left out; one above gets its direction
// and E_v(V) · (band per lux) · T_direct(z) in each band.
TEST(StarsInView, FrameStarsGivesTheIrradianceAboveTheAtmosphereTimesTheBeamTransmittance) {
    auto sr = ScenarioRenderer::create(test::sourceDir() / "scenarios/rit/nolight.toml",
                                       test::dataDirs());
    StarCatalog cat;
    cat.name = {"low", "high"};
    cat.ra_rad = {0.0, 0.0};
    cat.dec_rad = {0.0, 0.0};
    cat.vMag = {0.0, 1.5};
    const double az[2] = {1.0, 2.0}, alt[2] = {-0.1, 40 * kDeg};
    const std::array<double, kBands> perLuxBand{3.0e3, 2.0e-3};
    FrameSky sky;
    sky::frameStars(cat, az, alt, perLuxBand, sr->sky().table(), sr->tableBands(), &sky);
    ASSERT_EQ(sky.starCount, 1);
    const FrameStar& st = sky.stars[0];
    const Vec3 d = enuFromAzAlt(az[1], alt[1]);
    EXPECT_DOUBLE_EQ(st.dir_enu.z, d.z);
    EXPECT_DOUBLE_EQ(st.dir_enu.x, d.x);
    for (int b = 0; b < kBands; ++b) {
        const double t = sr->sky().table().directTransmittance(
            sr->tableBands()[static_cast<std::size_t>(b)], kPi / 2 - alt[1]);
        EXPECT_GT(t, 0.1);
        EXPECT_LT(t, 1.0);
        const double want =
            std::pow(10.0, -0.4 * (1.5 + 13.99)) * perLuxBand[static_cast<std::size_t>(b)] * t;
        EXPECT_NEAR(st.irradiance[b] / want, 1.0, 1e-12);
    }
}

// A 10 m grey quad, a camera and one star of band irradiance 1 [band m⁻²].
struct Bench {
    scene::Scene scene;
    RenderConfig cfg;
    Bench() {
        scene::Material m;
        m.name = "grey";
        m.reflectance = scene::greyReflectance(0.5);
        scene.materials.push_back(m);
        scene::Object o;
        o.name = "wall";
        // A vertical wall 5 m north of the origin, x in [-5, 5], z in [0, 10].
        o.mesh.vertices_m = {-5, 5, 0, 5, 5, 0, 5, 5, 10, -5, 5, 10};
        o.mesh.triangles = {0, 1, 2, 0, 2, 3};
        o.mesh.materials = {0, 0};
        scene.objects.push_back(o);
        cfg.camera.width = 64;
        cfg.camera.height = 48;
        cfg.camera.focalLength_m = 0.01;
        cfg.camera.pitchX_m = cfg.camera.pitchY_m = 2e-4;  // 1.15° per pixel
        cfg.bandWeight[kBandPe] = Spectrum(1.0);
        cfg.bandWeight[kBandW] = Spectrum(1.0);
        cfg.moonShape = Spectrum(1.0);
        cfg.nightSkyShape = Spectrum(1.0);
        cfg.embreeIsa = embreeIsaPin();
    }
    // Sum over the image of radiance × Ω_pixel with the camera looking along `look` and a star
    // in direction `star`.
    double flux(const Vec3& look, const Vec3& star) {
        Renderer r(scene, cfg);
        r.setCamera({{0, 0, 1}, Vec3{0, 0, 1} + look, {0, 0, 1}, 0.0});
        r.setTerms(kTermInView);
        FrameSky sky;  // no sky model: isotropic sky of zero radiance
        sky.starCount = 1;
        sky.stars[0].dir_enu = normalized(star);
        sky.stars[0].irradiance = {1.0, 1.0};
        ImageF pe(64, 48), w(64, 48);
        SerialExecutor ex;
        r.render(sky, pe.view(), w.view(), ex);
        double s = 0.0;
        int lit = 0;
        for (int y = 0; y < 48; ++y)
            for (int x = 0; x < 64; ++x)
                s += static_cast<double>(pe(x, y)), lit += pe(x, y) > 0.0f ? 1 : 0;
        EXPECT_LE(lit, 1);
        return s * cfg.camera.pitchX_m * cfg.camera.pitchY_m /
               (cfg.camera.focalLength_m * cfg.camera.focalLength_m);
    }
};

TEST(StarsInView, FluxInOnePixelNoneBehindGeometryOrBelowTheHorizon) {
    Bench b;
    // South, 20° up: open sky. The whole irradiance lands in one pixel.
    EXPECT_NEAR(b.flux({0, -1, 0.36}, {0.1, -1, 0.4}), 1.0, 1e-6);
    // North, 20° up: behind the wall (it reaches 40° up at 5 m... from 1 m height: atan(9/5)).
    EXPECT_EQ(b.flux({0, 1, 0.36}, {0.1, 1, 0.4}), 0.0);
    // South, 5° below the horizon, camera looking down at it: not drawn.
    EXPECT_EQ(b.flux({0, -1, -0.1}, {0.05, -1, -0.087}), 0.0);
}

}  // namespace
}  // namespace nvs::render
