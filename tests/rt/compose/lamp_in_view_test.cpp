// A lamp in view on the RIT lot, as a user sets it up (issue 29's acceptance): the shipped
// scenarios' scene, camera and night, rendered and passed through the camera chain.
//   - a 0.05 W pilot lamp 25 m away at 5 V manual gain: a small round saturated core, the
//     intensifier's halo disk in its radial profile at the radius the preset's tube geometry
//     gives (2 × cathode–MCP gap through the taper), and no light on the ground above the
//     moonlight's noise;
//   - the bare 40 W bulb with bright-source protection (scenarios/thesis-bare-bulb): a round
//     saturated image, no column spindle, and a lit pool whose radiance is the bulb's
//     irradiance E = I cos θ / r² (I from the luminous flux of a 40 W bulb, not from the
//     renderer's lamp model) times ρ/π.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <vector>

#include "rt/compose/scenario.h"
#include "rt/compose/scene_setup.h"
#include "sim/core/gamma_table.h"
#include "sim/core/photometry.h"
#include "sim/core/planck.h"
#include "sim/sensor/chain.h"

namespace nvs::rt {
namespace {

namespace fs = std::filesystem;
const fs::path kSource = NVS_SOURCE_DIR;
const DataDirs kDirs{kSource / "config", fs::path(NVS_BINARY_DIR) / "nvstim-cache"};
constexpr double kPi = 3.14159265358979323846;

struct Rendered {
    ImageF pe, w;
    Rendered(int width, int height) : pe(width, height), w(width, height) {}
};

double val(const ImageF& im, int x, int y) {
    return static_cast<double>(im(x, y));
}

Rendered renderNow(ScenarioRenderer& sr, double t_s = 0.0) {
    const Scenario& sc = sr.scenario();
    Rendered r(sc.width, sc.height);
    ThreadExecutor ex;
    sr.renderFrame(t_s, r.pe.view(), r.w.view(), ex);
    return r;
}

// The camera chain on a still input for `fields` fields (both fields of the woven frame filled
// and the phosphor settled); the last frame's counts and what the last field applied.
struct Video {
    std::vector<int> dc;
    int width = 0, height = 0, maxDc = 0;
    // A saturated cell: within 3 % of the level a full CCD well gives (offset + full well ×
    // video gain, the preset's figures), or the ADC's top.
    double satDc = 0.0;
    sensor::FieldInfo info;
    int at(int x, int y) const { return dc[static_cast<std::size_t>(y * width + x)]; }
};

Video runChain(const Scenario& sc, const ImageF& lpe, double gain_V, bool agc, int fields) {
    GammaTableCache tables;
    sensor::IiccdChain chain(sc.camera.params, sc.seed, kDirs.config, tables, {},
                             sensor::ControlSource::Command);
    sensor::CameraCommand cmd;
    cmd.gain_V = gain_V;
    cmd.agc = agc;
    Video v;
    for (int k = 0; k < fields; ++k) {
        v.info = chain.process(lpe.cview(), cmd, k / sc.camera.params.field_rate_Hz);
    }
    v.width = sc.width;
    v.height = sc.height;
    const sensor::CameraParams& cam = sc.camera.params;
    v.maxDc = (1 << cam.adc_bits) - 1;
    const double wellDc = cam.video_offset_dc + cam.full_well_e * cam.video_gain_dc_per_e;
    v.satDc = cam.full_well_e > 0.0 ? 0.97 * std::min<double>(v.maxDc, wellDc) : v.maxDc;
    for (int y = 0; y < sc.height; ++y) {
        for (int x = 0; x < sc.width; ++x)
            v.dc.push_back(chain.video()(x, y));
    }
    return v;
}

// The pixel where a lamp lands: the largest rise of the rendered radiance when it is switched on.
void lampPixel(const ImageF& on, const ImageF& off, int* px, int* py) {
    double best = -1.0;
    for (int y = 0; y < on.height(); ++y) {
        for (int x = 0; x < on.width(); ++x) {
            const double d = val(on, x, y) - val(off, x, y);
            if (d > best) best = d, *px = x, *py = y;
        }
    }
}

// The saturated cells connected to (x0, y0) (4-neighbours): count, bounding box and the
// longest saturated run along any one column that passes through them.
struct Blob {
    int count = 0, x0 = 1 << 30, x1 = -1, y0 = 1 << 30, y1 = -1, longestColumnRun = 0;
    int widthPx() const { return x1 - x0 + 1; }
    int heightPx() const { return y1 - y0 + 1; }
};

Blob saturatedBlob(const Video& v, int sx, int sy) {
    Blob b;
    std::vector<char> seen(v.dc.size(), 0);
    std::vector<std::pair<int, int>> stack;
    auto push = [&](int x, int y) {
        if (x < 0 || y < 0 || x >= v.width || y >= v.height) return;
        const std::size_t i = static_cast<std::size_t>(y * v.width + x);
        if (seen[i] || v.dc[i] < v.satDc) return;
        seen[i] = 1;
        stack.emplace_back(x, y);
    };
    // Start from the saturated cell nearest the lamp pixel (within 3 px).
    for (int r = 0; r <= 3 && stack.empty(); ++r) {
        for (int dy = -r; dy <= r; ++dy) {
            for (int dx = -r; dx <= r; ++dx)
                push(sx + dx, sy + dy);
        }
    }
    while (!stack.empty()) {
        const auto [x, y] = stack.back();
        stack.pop_back();
        ++b.count;
        b.x0 = std::min(b.x0, x), b.x1 = std::max(b.x1, x);
        b.y0 = std::min(b.y0, y), b.y1 = std::max(b.y1, y);
        push(x + 1, y), push(x - 1, y), push(x, y + 1), push(x, y - 1);
    }
    // Runs that pass through the blob: a column spindle grows out of the disk along its
    // column; a saturated patch elsewhere in the column (the lit ground under a bulb, beyond a
    // gap) is not one.
    for (int x = b.x0; x <= b.x1; ++x) {
        int run = 0;
        bool throughBlob = false;
        for (int y = 0; y < v.height; ++y) {
            const std::size_t i = static_cast<std::size_t>(y * v.width + x);
            if (v.at(x, y) >= v.satDc) {
                ++run;
                throughBlob = throughBlob || seen[i] != 0;
            } else {
                run = 0;
                throughBlob = false;
            }
            if (throughBlob) b.longestColumnRun = std::max(b.longestColumnRun, run);
        }
    }
    return b;
}

int saturatedTotal(const Video& v) {
    return static_cast<int>(
        std::count_if(v.dc.begin(), v.dc.end(), [&](int d) { return d >= v.satDc; }));
}

// Mean of (a − b) in rings of 20 µm on the CCD (cells 11 × 13 µm) about (cx, cy).
std::vector<double> radialProfile(const Video& a, const Video& b, double cx, double cy,
                                  double pitchX_um, double pitchY_um, int rings) {
    std::vector<double> sum(static_cast<std::size_t>(rings), 0.0), n(sum);
    for (int y = 0; y < a.height; ++y) {
        for (int x = 0; x < a.width; ++x) {
            const double r = std::hypot((x - cx) * pitchX_um, (y - cy) * pitchY_um);
            const int k = static_cast<int>(r / 20.0);
            if (k >= rings) continue;
            sum[static_cast<std::size_t>(k)] += a.at(x, y) - b.at(x, y);
            n[static_cast<std::size_t>(k)] += 1.0;
        }
    }
    for (int k = 0; k < rings; ++k)
        sum[k] /= std::max(1.0, n[k]);
    return sum;
}

// Asphalt pixels of the lot whose ground point lies between r0 and r1 (horizontally) from a
// point of the lot.
std::vector<std::pair<int, int>> asphaltRing(ScenarioRenderer& sr, Vec3 centre, double r0_m,
                                             double r1_m) {
    const int asphalt = sr.scene().materialIndex("asphalt");
    std::vector<std::pair<int, int>> px;
    for (int y = 0; y < sr.scenario().height; ++y) {
        for (int x = 0; x < sr.scenario().width; ++x) {
            Vec3 p;
            int m = -1, o = -1;
            if (!sr.renderer().pixelHit(x, y, &p, &m, &o) || m != asphalt) continue;
            const double d = std::hypot(p.x - centre.x, p.y - centre.y);
            if (d >= r0_m && d < r1_m) px.emplace_back(x, y);
        }
    }
    return px;
}

double meanDc(const Video& v, const std::vector<std::pair<int, int>>& px) {
    double s = 0.0;
    for (const auto& [x, y] : px)
        s += v.at(x, y);
    return s / static_cast<double>(px.size());
}

double sdDc(const Video& v, const std::vector<std::pair<int, int>>& px) {
    const double m = meanDc(v, px);
    double s = 0.0;
    for (const auto& [x, y] : px)
        s += (v.at(x, y) - m) * (v.at(x, y) - m);
    return std::sqrt(s / static_cast<double>(px.size() - 1));
}

// The thesis-stlamp night (street lamp on, 5 V manual) on the scene with the pilot lamp.
Scenario stlampWithPilot() {
    Scenario sc = loadScenario(kSource / "scenarios/thesis-stlamp", kDirs.config);
    sc.scene.sceneFile = kSource / "scenarios/rit/scene_bulb.toml";
    sc.scene.lampsOn = std::vector<std::string>{"street_lamp", "pilot_lamp"};
    return sc;
}

TEST(LampInView, PilotLampIsASmallRoundCoreWithTheHaloDiskAndLightsNoGround) {
    const Scenario sc = stlampWithPilot();
    ASSERT_FALSE(sc.platform.agc);
    auto sr = ScenarioRenderer::create(sc, kDirs);
    const int pilot = sr->scene().lampIndex("pilot_lamp");
    ASSERT_GE(pilot, 0);
    const Vec3 lampPos = sr->scene().lamps[static_cast<std::size_t>(pilot)].position_m;
    const Vec3 camPos = sr->scene().camera.position_m;
    const Rendered on = renderNow(*sr);
    sr->renderer().setLampOn(pilot, false);
    const Rendered off = renderNow(*sr);
    int lx = 0, ly = 0;
    lampPixel(on.pe, off.pe, &lx, &ly);
    const Video von = runChain(sc, on.pe, sc.platform.gain_V, false, 6);
    const Video voff = runChain(sc, off.pe, sc.platform.gain_V, false, 6);
    const sensor::CameraParams& cam = sc.camera.params;
    const double px_um = cam.pitch_x_um, py_um = cam.pitch_y_um;

    // Saturated core: ≤ 0.1 % of the frame, round on the sensor.
    const Blob b = saturatedBlob(von, lx, ly);
    const int added = saturatedTotal(von) - saturatedTotal(voff);
    const double frac = static_cast<double>(b.count) / (sc.width * sc.height);
    const double hw = (b.heightPx() * py_um) / (b.widthPx() * px_um);
    std::printf(
        "pilot lamp %.1f m from the camera at (%d, %d), %.1f V manual: saturated %d px "
        "(%.3f %% of the frame; %d more than without it), %d x %d px, h/w %.2f on the "
        "sensor\n",
        norm(lampPos - camPos), lx, ly, sc.platform.gain_V, b.count, 100 * frac, added, b.widthPx(),
        b.heightPx(), hw);
    ASSERT_GT(b.count, 0) << "the pilot lamp does not saturate";
    EXPECT_LE(frac, 0.001);
    EXPECT_LE(added, sc.width * sc.height / 1000);
    EXPECT_LT(std::abs(std::log(hw)), std::log(1.3));

    // The halo ring: from the preset's stated tube geometry, photoelectrons backscattered at the
    // MCP land within 2 × the cathode–MCP gap on the photocathode; the taper demagnifies that
    // onto the CCD.
    const double haloR_um = 2.0 * cam.halo_gap_um / cam.taper_magnification;
    const double cx = 0.5 * (b.x0 + b.x1), cy = 0.5 * (b.y0 + b.y1);
    const std::vector<double> prof = radialProfile(von, voff, cx, cy, px_um, py_um, 20);
    const double coreR_um = 0.5 * std::max(b.widthPx() * px_um, b.heightPx() * py_um);
    // The disk's edge: the outermost ring still at half the level of the rings between the
    // saturated core and the disk radius (its shoulder).
    double shoulder = 0.0;
    int nShoulder = 0;
    for (int k = 0; k < 20; ++k) {
        const double r = 20.0 * (k + 0.5);
        if (r > coreR_um + 20.0 && r < 0.8 * haloR_um) shoulder += prof[k], ++nShoulder;
    }
    ASSERT_GT(nShoulder, 0) << "the saturated core covers the halo disk";
    shoulder /= nShoulder;
    double edge_um = 0.0;
    for (int k = 0; k < 20; ++k) {
        if (20.0 * (k + 0.5) > coreR_um && prof[k] >= 0.5 * shoulder) edge_um = 20.0 * (k + 1);
    }
    std::printf("radial profile (DC above the frame without the lamp, 20 µm rings):");
    for (int k = 0; k < 20; ++k)
        std::printf(" %.1f", prof[k]);
    std::printf(
        "\nhalo disk radius 2 x %.0f µm / %.3f = %.0f µm on the CCD (%.1f x %.1f px); "
        "shoulder %.1f DC, half-level edge %.0f µm\n",
        cam.halo_gap_um, cam.taper_magnification, haloR_um, haloR_um / px_um, haloR_um / py_um,
        shoulder, edge_um);
    EXPECT_GT(shoulder, 2.0) << "no halo shoulder above the background";
    EXPECT_NEAR(edge_um, haloR_um, 0.25 * haloR_um);
    const double beyond = 0.5 * (prof[static_cast<std::size_t>(1.4 * haloR_um / 20)] +
                                 prof[static_cast<std::size_t>(1.6 * haloR_um / 20)]);
    EXPECT_LT(beyond, 0.2 * shoulder) << "the profile does not fall beyond the disk";

    // Too weak to light the ground: asphalt 1.5–4 m from the lamp's foot, with and without it.
    const auto ring = asphaltRing(*sr, {lampPos.x, lampPos.y, 0.0}, 1.5, 4.0);
    ASSERT_GT(ring.size(), 200u);
    double lampShare = 0.0;
    for (const auto& [x, y] : ring)
        lampShare += (val(on.pe, x, y) - val(off.pe, x, y)) / val(off.pe, x, y);
    lampShare /= static_cast<double>(ring.size());
    const double dMean = meanDc(von, ring) - meanDc(voff, ring);
    const double sigma = sdDc(voff, ring);
    std::printf(
        "ground 1.5-4 m from it (%zu px): lamp adds %.2f %% of the radiance, %.2f DC to "
        "the mean (%.1f DC without it; pixel noise %.1f DC)\n",
        ring.size(), 100 * lampShare, dMean, meanDc(voff, ring), sigma);
    // What the lamp adds in expectation (its share of the signal above the offset) and what it
    // added: both a small part of one pixel's noise.
    const double expectedAdd = lampShare * (meanDc(voff, ring) - sc.camera.params.video_offset_dc);
    std::printf("expected rise %.2f DC\n", expectedAdd);
    EXPECT_LT(expectedAdd, 0.25 * sigma);
    EXPECT_LT(std::abs(dMean), 0.25 * sigma);
}

// A 40 W general-service tungsten bulb gives about 450–495 lm: US FTC Lighting Facts / ENERGY
// STAR equivalence, 40 W ↔ 450 lm; GE's incandescent table, 40 W A19 495 lm (GE Lighting,
// "Lumens and watts"). Taken as 470 lm ± 5 %.
constexpr double kBulbFlux_lm = 470.0;

TEST(LampInView, BareBulbWithBspIsARoundDiskNoSpindleAndLightsItsPool) {
    const Scenario sc = loadScenario(kSource / "scenarios/thesis-bare-bulb", kDirs.config);
    ASSERT_TRUE(sc.platform.agc);
    auto sr = ScenarioRenderer::create(sc, kDirs);
    const int bulb = sr->scene().lampIndex("bare_bulb");
    ASSERT_GE(bulb, 0);
    const scene::Lamp& lamp = sr->scene().lamps[static_cast<std::size_t>(bulb)];
    const Rendered on = renderNow(*sr);
    sr->renderer().setLampOn(bulb, false);
    const Rendered off = renderNow(*sr);
    int lx = 0, ly = 0;
    lampPixel(on.pe, off.pe, &lx, &ly);
    const Video v = runChain(sc, on.pe, sc.platform.gain_V, true, 6);
    const sensor::CameraParams& cam = sc.camera.params;

    // A round saturated image and no column spindle.
    const Blob b = saturatedBlob(v, lx, ly);
    const double hw = (b.heightPx() * cam.pitch_y_um) / (b.widthPx() * cam.pitch_x_um);
    std::printf(
        "bare bulb %.1f m away at (%d, %d): saturated %d px (%.3f %%), %d x %d px, h/w "
        "%.2f on the sensor, longest saturated column run %d px\n",
        norm(lamp.position_m - sr->scene().camera.position_m), lx, ly, b.count,
        100.0 * b.count / (sc.width * sc.height), b.widthPx(), b.heightPx(), hw,
        b.longestColumnRun);
    ASSERT_GE(b.count, 50);
    EXPECT_LT(std::abs(std::log(hw)), std::log(1.3));
    EXPECT_LE(b.longestColumnRun, 1.3 * b.widthPx() * cam.pitch_x_um / cam.pitch_y_um);

    // The pool: E = I cos θ / r² with I from the bulb's luminous flux, carried into the camera's
    // photoelectron band with the 2700 K Planck spectrum's shape; L = (1 − s) ρ E / π with the
    // asphalt's reflectance from the scene file, weighted by that spectrum in the band.
    const RenderConfig rc = renderConfigFor(sr->camera(), sc.width, sc.height);
    const Spectrum& wPe = rc.bandWeight[render::kBandPe];
    const Spectrum planck = planckRadiance_W_m2_sr_nm(lamp.temperature_K);
    const Photometry phot(kDirs.config);
    const double iPe = kBulbFlux_lm / (4 * kPi) * integrateProduct_nm(planck, wPe) /
                       phot.photometricIntegral(planck);
    const scene::Material& asphalt =
        sr->scene().materials[static_cast<std::size_t>(sr->scene().materialIndex("asphalt"))];
    const double rhoPe =
        integrateProduct_nm(planck * asphalt.reflectance, wPe) / integrateProduct_nm(planck, wPe);
    const Vec3 foot{lamp.position_m.x, lamp.position_m.y, 0.0};
    const auto pool = asphaltRing(*sr, foot, 2.0, 3.0);
    ASSERT_GT(pool.size(), 200u);
    std::vector<double> ratio;
    for (const auto& [x, y] : pool) {
        Vec3 p;
        int m = -1, o = -1;
        sr->renderer().pixelHit(x, y, &p, &m, &o);
        const Vec3 d = lamp.position_m - p;
        const double r = norm(d);
        const double lPe = (1.0 - asphalt.specularity) * rhoPe * iPe * (d.z / r) / (r * r) / kPi;
        ratio.push_back((val(on.pe, x, y) - val(off.pe, x, y)) / lPe);
    }
    std::sort(ratio.begin(), ratio.end());
    const double median = ratio[ratio.size() / 2];
    const double lit = static_cast<double>(std::count_if(ratio.begin(), ratio.end(),
                                                         [](double q) { return q > 0.0; })) /
                       static_cast<double>(ratio.size());
    std::printf(
        "pool 2-3 m from the foot (%zu asphalt px; nearer is not asphalt, %.0f %% lit): rendered / "
        "(rho E / pi) "
        "median %.3f (I_pe = %.3g pe/s/sr from %.0f lm, rho_pe %.3f)\n",
        pool.size(), 100 * lit, median, iPe, kBulbFlux_lm, rhoPe);
    // Tolerance: the flux's ±5 % and the blackbody shape standing for a real filament's.
    EXPECT_NEAR(median, 1.0, 0.15);

    // The gain BSP chose and the DC it gives. The bulb's image glares over its surroundings
    // (the blur's tails of a core far above full well), so the pool's own DC is measured against
    // the same frame with the bulb in view but its light on the ground left out (BSP then sees
    // a little less cathode current: its frame is scaled by the ratio of the MCP gains). The output
    // is linear above the offset (gamma 1): the pool's DC, inner ring (2.5–3 m from the foot;
    // nearer, the glare reaches 70 DC) against outer (4.5–5 m), falls as ρE/π computed above.
    sr->renderer().setLampOn(bulb, true);
    sr->renderer().setTerms(render::kTermAll & ~render::kTermLamps);
    const Rendered glare = renderNow(*sr);
    sr->renderer().setTerms(render::kTermAll);
    const Video vg = runChain(sc, glare.pe, sc.platform.gain_V, true, 6);
    const double gainRatio = v.info.mcp_gain / vg.info.mcp_gain;
    auto ringMeans = [&](double r0, double r1, double* dPool, double* lPred) {
        double sDc = 0.0, sL = 0.0;
        const auto px = asphaltRing(*sr, foot, r0, r1);
        for (const auto& [x, y] : px) {
            Vec3 p;
            int m = -1, o = -1;
            sr->renderer().pixelHit(x, y, &p, &m, &o);
            const Vec3 d = lamp.position_m - p;
            const double r = norm(d);
            sDc +=
                v.at(x, y) - cam.video_offset_dc - gainRatio * (vg.at(x, y) - cam.video_offset_dc);
            sL += (1.0 - asphalt.specularity) * rhoPe * iPe * (d.z / r) / (r * r) / kPi;
        }
        *dPool = sDc / static_cast<double>(px.size()), *lPred = sL / static_cast<double>(px.size());
        return static_cast<int>(px.size());
    };
    double innerDc = 0.0, innerL = 0.0, outerDc = 0.0, outerL = 0.0;
    const int nIn = ringMeans(2.5, 3.0, &innerDc, &innerL);
    const int nOut = ringMeans(4.5, 5.0, &outerDc, &outerL);
    const auto moonlit = asphaltRing(*sr, foot, 8.0, 12.0);
    std::printf(
        "BSP: tube control %.2f V (the preset's; commanded %.2f V), MCP electron gain "
        "%.3f = %.1f x BSP factor %.5f (cathode current %.3g A; %.5f without the pool); "
        "pool %.1f DC at 2.5-3 m (%d px; %.1f DC from the bulb's light), %.1f DC at 4.5-5 m "
        "(%d px; %.1f DC), moonlit asphalt 8-12 m %.1f DC, offset %.1f DC; the pool's "
        "DC inner/outer %.2f, rho E/pi %.2f; %.3g DC per pe/s/m2/sr\n",
        v.info.gain_V, sc.platform.gain_V, v.info.mcp_gain, v.info.mcp_gain / v.info.bsp_factor,
        v.info.bsp_factor, v.info.cathode_current_A, vg.info.bsp_factor,
        meanDc(v, asphaltRing(*sr, foot, 2.5, 3.0)), nIn, innerDc,
        meanDc(v, asphaltRing(*sr, foot, 4.5, 5.0)), nOut, outerDc, meanDc(v, moonlit),
        cam.video_offset_dc, innerDc / outerDc, innerL / outerL, outerDc / outerL);
    ASSERT_GT(nIn, 100);
    ASSERT_GT(nOut, 100);
    EXPECT_LT(v.info.bsp_factor, 1.0) << "BSP did not act on the bulb";
    EXPECT_LT(meanDc(v, asphaltRing(*sr, foot, 2.5, 3.0)), 0.9 * v.maxDc) << "the pool is clipped";
    EXPECT_NEAR((innerDc / outerDc) / (innerL / outerL), 1.0, 0.15);
}

// Headlights behave as the bulb at their own intensity: in the last frame of
// scenarios/thesis-headlights (truck 27.5 m away, BSP) each headlamp's glare lobe is a round
// saturated disk and neither blooms along its column.
TEST(LampInView, HeadlightsAreTwoRoundDisksWithoutSpindles) {
    const Scenario sc = loadScenario(kSource / "scenarios/thesis-headlights", kDirs.config);
    auto sr = ScenarioRenderer::create(sc, kDirs);
    const double t = sr->frameTime_s(29);
    const sensor::CameraParams& cam = sc.camera.params;
    const Rendered on = renderNow(*sr, t);
    const Video v = runChain(sc, on.pe, sc.platform.gain_V, true, 6);
    for (const char* name : {"head_left_glare", "head_right_glare"}) {
        const int l = sr->scene().lampIndex(name);
        ASSERT_GE(l, 0);
        sr->renderer().setLampOn(l, false);
        const Rendered off = renderNow(*sr, t);
        sr->renderer().setLampOn(l, true);
        int lx = 0, ly = 0;
        lampPixel(on.pe, off.pe, &lx, &ly);
        const Blob b = saturatedBlob(v, lx, ly);
        const double hw = (b.heightPx() * cam.pitch_y_um) / (b.widthPx() * cam.pitch_x_um);
        std::printf(
            "%s at (%d, %d): saturated %d px, %d x %d px, h/w %.2f on the sensor, "
            "longest saturated column run %d px; BSP factor %.5f\n",
            name, lx, ly, b.count, b.widthPx(), b.heightPx(), hw, b.longestColumnRun,
            v.info.bsp_factor);
        ASSERT_GE(b.count, 50);
        EXPECT_LT(std::abs(std::log(hw)), std::log(1.3));
        EXPECT_LE(b.longestColumnRun, 1.3 * b.widthPx() * cam.pitch_x_um / cam.pitch_y_um);
    }
}

}  // namespace
}  // namespace nvs::rt
