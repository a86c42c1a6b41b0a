// The thermal band on the shipped RIT scene (docs/thermal.md, "Rendering"): the scene's surface
// classes through the heat balance over the thesis night's weather, rendered with the night's
// LWIR table, checked against an independent spectral integration and against what the thesis
// used the scene for (aluminium fiducials cold against grass at night, §4; vehicle tops colder
// than their sides under the clear sky, Appendix M).
#include "rt/compose/thermal_scene.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <vector>

#include "rt/compose/scenario.h"
#include "rt/compose/scene_setup.h"
#include "sim/lwir/absorption.h"
#include "sim/lwir/humidity.h"

namespace nvs::rt {
namespace {
namespace fs = std::filesystem;

const fs::path kSource = NVS_SOURCE_DIR;
const DataDirs kDirs{kSource / "config", fs::path(NVS_BINARY_DIR) / "nvstim-cache"};

struct Night {
    std::unique_ptr<ScenarioRenderer> sr;
    std::unique_ptr<ThermalScene> thermal;
    double t_s = 0.0;  // POSIX
    ImageF radiance;
};

Night& nolight() {
    static Night n = [] {
        Night night;
        fs::create_directories(kDirs.cache);
        night.sr =
            ScenarioRenderer::create(kSource / "scenarios/thesis-nolight/scenario.toml", kDirs);
        const Scenario& sc = night.sr->scenario();
        night.t_s = sc.utcStart_unix_s;
        ThermalSceneSpec spec;
        spec.weatherFile = kSource / "config/thermal/weather/rochester-1998-09-02.csv";
        spec.materialsFile = kSource / "config/thermal/materials.toml";
        night.sr->prepare(0.0);
        night.thermal = std::make_unique<ThermalScene>(
            night.sr->scene(), night.sr->renderer(), sc.scene.site, night.sr->epoch(),
            sc.utcStart_unix_s, night.t_s, night.t_s + 60.0, spec, kDirs);
        const Renderer& r = night.sr->renderer();
        night.radiance = ImageF(r.camera().width, r.camera().height);
        SerialExecutor exec;
        night.sr->renderer().renderThermal(night.thermal->frame(night.t_s), night.radiance.view(),
                                           exec);
        // The frame as brightness temperature, 275-300 K on 0-255, to look at.
        std::FILE* f = std::fopen((fs::path(NVS_BINARY_DIR) / "thermal_nolight.pgm").c_str(), "wb");
        if (f) {
            std::fprintf(f, "P5\n%d %d\n255\n", night.radiance.width(), night.radiance.height());
            for (int y = 0; y < night.radiance.height(); ++y) {
                for (int x = 0; x < night.radiance.width(); ++x) {
                    const double t = night.thermal->lwirTable().brightnessTemperature_K(
                        static_cast<double>(night.radiance(x, y)));
                    std::fputc(static_cast<int>(std::clamp((t - 275.0) / 25.0 * 255.0, 0.0, 255.0)),
                               f);
                }
            }
            std::fclose(f);
        }
        return night;
    }();
    return n;
}

// Mean brightness temperature of the pixels whose primary hit is on `material`.
double brightnessOf(Night& n, const std::string& material, int* count) {
    const Renderer& r = n.sr->renderer();
    const int m = n.sr->scene().materialIndex(material);
    double sum = 0.0;
    *count = 0;
    for (int y = 0; y < r.camera().height; ++y) {
        for (int x = 0; x < r.camera().width; ++x) {
            Vec3 p;
            int mat = -1, obj = -1;
            if (!r.pixelHit(x, y, &p, &mat, &obj) || mat != m) continue;
            sum += n.thermal->lwirTable().brightnessTemperature_K(
                static_cast<double>(n.radiance(x, y)));
            ++*count;
        }
    }
    return *count > 0 ? sum / *count : 0.0;
}

TEST(ThermalScene, AluminiumFiducialsAreColdAgainstGrassAtNight) {
    Night& n = nolight();
    int nAl = 0, nGrass = 0, nAsphalt = 0, nWhite = 0;
    const double al = brightnessOf(n, "polished_aluminum", &nAl);
    const double grass = brightnessOf(n, "grass", &nGrass);
    const double asphalt = brightnessOf(n, "asphalt", &nAsphalt);
    const double white = brightnessOf(n, "wht_panel", &nWhite);
    const double air = n.thermal->weather().at(n.t_s).air_K;
    std::printf(
        "1998-09-02 01:00Z, air %.2f K; brightness temperature: aluminium %.2f K (%d px), "
        "grass %.2f K (%d px), asphalt %.2f K (%d px), white panel %.2f K (%d px)\n",
        air, al, nAl, grass, nGrass, asphalt, nAsphalt, white, nWhite);
    ASSERT_GT(nAl, 20);
    ASSERT_GT(nGrass, 1000);
    // Polished aluminium (ε 0.05) emits little and mirrors the sky and the surroundings: colder
    // than the grass beside it (the thesis, §4).
    EXPECT_LT(al, grass - 2.0);
    // A clear night: asphalt, which stored the day's heat, is warmer than grass.
    EXPECT_GT(asphalt, grass);
}

// Each pixel against a direct spectral integration through sim/lwir's absorption model:
//   L = ε ∫R τ(λ) B(λ, T) dλ + ∫R (1 − τ(λ)) B(λ, T_air) dλ + (1 − ε) τ_band L_env
// (the last term, 2 % of grass's radiance, from the renderer's own environment).
TEST(ThermalScene, GrassPixelsMatchADirectSpectralIntegration) {
    Night& n = nolight();
    const Renderer& r = n.sr->renderer();
    const lwir::AbsorptionData data = lwir::AbsorptionData::load(kDirs.config);
    const thermal::WeatherSample w = n.thermal->weather().at(n.t_s);
    lwir::AirState air;
    air.temperature_K = w.air_K;
    air.vapourPressure_Pa = lwir::vapourPressureFromDewPoint_Pa(w.dewPoint_K);
    const lwir::BandResponse band = lwir::BandResponse::flat(7.5, 13.5);
    const int grass = n.sr->scene().materialIndex("grass");
    int checked = 0;
    double worst = 0.0;
    for (int y = 10; y < r.camera().height; y += 37) {
        for (int x = 10; x < r.camera().width; x += 41) {
            Vec3 p;
            int mat = -1, obj = -1;
            if (!r.pixelHit(x, y, &p, &mat, &obj) || mat != grass) continue;
            const int cls = r.thermalClassOfPixel(x, y);
            ASSERT_GE(cls, 0);
            const double range_m = norm(p - n.sr->scene().camera.position_m);
            const double t_K = r.thermalPixelTemperature_K(n.thermal->frame(n.t_s), x, y);
            Vec3 normal;
            double svf = 0.0;
            r.pixelSurface(x, y, &normal, &svf);
            const Vec3 view = normalized(n.sr->scene().camera.position_m - p);
            const double eps = thermal::directionalEmissivity(
                n.thermal->classes()[static_cast<std::size_t>(cls)].material, dot(normal, view));
            const lwir::Spectral tau = lwir::homogeneousTransmittance(data, air, range_m);
            lwir::Spectral absorb{};
            for (std::size_t i = 0; i < absorb.size(); ++i)
                absorb[i] = 1.0 - tau[i];
            const double env = svf * n.thermal->lwirTable().skyDiffuseRadiance_W_m2_sr() +
                               (1.0 - svf) * n.thermal->frame(n.t_s).groundRadiance;
            const double direct =
                eps * lwir::bandIntegral_W_m2_sr(band, tau, t_K) +
                lwir::bandIntegral_W_m2_sr(band, absorb, w.air_K) +
                (1.0 - eps) * n.thermal->lwirTable().path(range_m).transmittance * env;
            const double rel = static_cast<double>(n.radiance(x, y)) / direct - 1.0;
            worst = std::max(worst, std::fabs(rel));
            ++checked;
        }
    }
    std::printf("%d grass pixels, worst |rendered/direct - 1| = %.4f\n", checked, worst);
    ASSERT_GT(checked, 20);
    EXPECT_LT(worst, 0.01);
}

// Appendix M: the vehicle's top is colder than its sides, exposed to the clear sky.
TEST(ThermalScene, TruckRoofColderThanItsSides) {
    Night& n = nolight();
    const auto& surfaces = n.thermal->surfaces();
    const int red = n.sr->scene().materialIndex("red_truck");
    double roof = 0.0, roofArea = 0.0, side = 0.0, sideArea = 0.0;
    for (std::size_t i = 0; i < surfaces.size(); ++i) {
        const render::ThermalSurface& s = surfaces[i];
        if (s.material != red) continue;
        const double t_K = n.thermal->temperatures().at(i, n.t_s);
        const double tilt_deg = s.tilt_rad * 180.0 / 3.14159265358979;
        if (tilt_deg < 22.5 && s.skyView > 0.75) roof += t_K * s.area_m2, roofArea += s.area_m2;
        if (tilt_deg > 67.5 && tilt_deg < 112.5) side += t_K * s.area_m2, sideArea += s.area_m2;
    }
    ASSERT_GT(roofArea, 0.5);
    ASSERT_GT(sideArea, 0.5);
    std::printf("red truck: roof %.2f K (%.1f m2), sides %.2f K (%.1f m2)\n", roof / roofArea,
                roofArea, side / sideArea, sideArea);
    EXPECT_LT(roof / roofArea, side / sideArea - 0.5);
}

// Shared primary hits (docs/thermal.md, "Shared primary hits"): the thermal camera of
// thesis-nolight-lwir (640 × 512, 18 mm, 24.1° across) boresighted with the intensified camera of
// thesis-nolight (768 × 494, 22.0° across) takes that camera's G-buffer where it lies inside its
// image and casts its own rays outside. Checked against the thermal camera rendered with its own
// rays at every pixel (its own scenario): the nearest sample moves an edge by at most half an
// intensified pixel (0.25 mrad against the thermal pixel's 0.67), so pixels differ only along
// edges.
TEST(ThermalScene, SharedPrimaryHitsMatchTheThermalCamerasOwnRays) {
    SerialExecutor exec;
    auto own =
        ScenarioRenderer::create(kSource / "scenarios/thesis-nolight-lwir/scenario.toml", kDirs);
    const Scenario& sc = own->scenario();
    const std::unique_ptr<ThermalScene> ownThermal = ThermalScene::forScenario(*own, kDirs);
    const double t_s = sc.utcStart_unix_s;
    const int w = own->renderer().camera().width, h = own->renderer().camera().height;
    ImageF exact(w, h), shared(w, h);
    own->renderer().renderThermal(ownThermal->frame(t_s), exact.view(), exec);

    Night& n = nolight();  // the intensified camera's renderer
    Renderer& r = n.sr->renderer();
    const std::unique_ptr<ThermalScene> sharedThermal =
        ThermalScene::forChannel(*n.sr, *sc.camera.thermalParams, *sc.scene.thermal, kDirs);
    r.setThermalView(own->renderer().camera());
    const int ownRays = r.thermalOwnRays();
    r.renderThermal(sharedThermal->frame(t_s), shared.view(), exec);

    const lwir::LwirTable& table = ownThermal->lwirTable();
    int within = 0, count = 0;
    double sum = 0.0, worst = 0.0;
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const double d = table.brightnessTemperature_K(static_cast<double>(shared(x, y))) -
                             table.brightnessTemperature_K(static_cast<double>(exact(x, y)));
            sum += d;
            worst = std::max(worst, std::fabs(d));
            within += std::fabs(d) < 0.05 ? 1 : 0;
            ++count;
        }
    }
    std::printf(
        "shared hits: %d of %d pixels with rays of their own; %.2f %% within 0.05 K of "
        "the own-ray frame, mean difference %+.4f K, worst %.2f K\n",
        ownRays, count, 100.0 * within / count, sum / count, worst);
    // The 18 mm view is wider than the intensified one: a border of its own rays.
    EXPECT_GT(ownRays, count / 20);
    EXPECT_LT(ownRays, count / 2);
    EXPECT_GT(within, count * 95 / 100);
    EXPECT_LT(std::fabs(sum / count), 0.02);
    // Put the renderer back for the other tests.
    r.setThermalView(r.camera());
}

// A lamp housing (docs/thermal.md, "Heat sources"): thesis-stlamp-lwir, the street lamp in view lit
// for hours. Its steel box, heated by the 40 W bulb (config/thermal/materials.toml, lamp_box_40w),
// reads warmer than the air and than its own unheated pole and arm (the same paint, "sign"), which
// the clear sky cools below the air; in thesis-nolight-lwir, unlit, the same box is no warmer than
// its pole. Brightness temperatures of the rendered pixels by material, frame 0.
TEST(ThermalScene, LitLampHousingIsWarmerThanItsPole) {
    SerialExecutor exec;
    const auto meanBrightness = [&](const char* scenario, const char* housing, int* nHousing,
                                    double* pole, int* nPole, double* air_K) {
        auto sr =
            ScenarioRenderer::create(kSource / "scenarios" / scenario / "scenario.toml", kDirs);
        const std::unique_ptr<ThermalScene> thermal = ThermalScene::forScenario(*sr, kDirs);
        (void)sr->prepare(0.0);
        Renderer& r = sr->renderer();
        ImageF radiance(r.camera().width, r.camera().height);
        const double t = sr->scenario().utcStart_unix_s;
        r.renderThermal(thermal->frame(t), radiance.view(), exec);
        const int hMat = sr->scene().materialIndex(housing);
        const int pMat = sr->scene().materialIndex("sign");
        const Vec3 lamp = sr->scene()
                              .lamps[static_cast<std::size_t>(sr->scene().lampIndex("street_lamp"))]
                              .position_m;
        int lampObj = -1;
        for (std::size_t i = 0; i < sr->scene().objects.size(); ++i)
            if (sr->scene().objects[i].name == "street_lamp_pole") lampObj = static_cast<int>(i);
        double sumH = 0.0, sumP = 0.0;
        *nHousing = *nPole = 0;
        for (int y = 0; y < r.camera().height; ++y) {
            for (int x = 0; x < r.camera().width; ++x) {
                Vec3 p;
                int mat = -1, obj = -1;
                if (!r.pixelHit(x, y, &p, &mat, &obj) || obj != lampObj) continue;
                const double tb = thermal->lwirTable().brightnessTemperature_K(
                    static_cast<double>(radiance(x, y)));
                // The housing: the 25-cm box whose bottom holds the lamp
                // (scenarios/rit/make_scene.py).
                const Vec3 d = p - lamp;
                const bool box = d.z > -0.01 && d.z < 0.26 && std::hypot(d.x, d.y) < 0.18;
                if (box && mat == hMat) {
                    sumH += tb;
                    ++*nHousing;
                } else if (!box && mat == pMat) {
                    sumP += tb;
                    ++*nPole;
                }
            }
        }
        *pole = *nPole > 0 ? sumP / *nPole : 0.0;
        *air_K = thermal->weather().at(t).air_K;
        return *nHousing > 0 ? sumH / *nHousing : 0.0;
    };
    int nLit = 0, nLitPole = 0, nOff = 0, nOffPole = 0;
    double litPole = 0.0, offPole = 0.0, litAir = 0.0, offAir = 0.0;
    const double lit =
        meanBrightness("thesis-stlamp-lwir", "lamp_box", &nLit, &litPole, &nLitPole, &litAir);
    const double off =
        meanBrightness("thesis-nolight-lwir", "sign", &nOff, &offPole, &nOffPole, &offAir);
    std::printf(
        "lamp housing, brightness temperature: lit %.1f K (%d px; pole %.1f K, %d px; air "
        "%.1f K), unlit %.1f K (%d px; pole %.1f K, %d px; air %.1f K)\n",
        lit, nLit, litPole, nLitPole, litAir, off, nOff, offPole, nOffPole, offAir);
    ASSERT_GT(nLit, 20);
    ASSERT_GT(nLitPole, 20);
    ASSERT_GT(nOff, 20);
    EXPECT_GT(lit, litAir + 3.0);
    EXPECT_GT(lit, litPole + 5.0);
    EXPECT_LT(off, offPole + 2.0);
}

// Heat sources (docs/thermal.md, "Heat sources"): vehicle-drive-lwir's truck drives with its engine
// running, its front toward the camera. Its hood (painted steel over a 343 K engine bay) is the
// warmest of the truck in view, its black roof, open to the clear sky, the coldest; the person's
// face warmer than the grass. Brightness temperatures of the rendered pixels by
// material at t = 1/3 s (frame 10), where the whole front of the truck is in view.
TEST(ThermalScene, RunningTruckHoodIsWarmAndItsRoofCold) {
    SerialExecutor exec;
    auto sr =
        ScenarioRenderer::create(kSource / "scenarios/vehicle-drive-lwir/scenario.toml", kDirs);
    const std::unique_ptr<ThermalScene> thermal = ThermalScene::forScenario(*sr, kDirs);
    const double t_s = 10.0 / 30.0;
    (void)sr->prepare(t_s);
    Renderer& r = sr->renderer();
    ImageF radiance(r.camera().width, r.camera().height);
    r.renderThermal(thermal->frame(sr->scenario().utcStart_unix_s + t_s), radiance.view(), exec);
    std::map<int, std::pair<double, int>> byMaterial;  // sum of brightness temperature, pixels
    for (int y = 0; y < r.camera().height; ++y) {
        for (int x = 0; x < r.camera().width; ++x) {
            Vec3 p;
            int mat = -1, obj = -1;
            if (!r.pixelHit(x, y, &p, &mat, &obj)) continue;
            auto& e = byMaterial[mat];
            e.first +=
                thermal->lwirTable().brightnessTemperature_K(static_cast<double>(radiance(x, y)));
            ++e.second;
        }
    }
    const auto mean = [&](const char* name, int* n) {
        const auto& e = byMaterial[sr->scene().materialIndex(name)];
        *n = e.second;
        return e.second > 0 ? e.first / e.second : 0.0;
    };
    int nHood = 0, nPipe = 0, nRoof = 0, nBody = 0, nGrass = 0, nFace = 0;
    const double hood = mean("red_truck_hood", &nHood), pipe = mean("tailpipe", &nPipe);
    const double roof = mean("blk_truck", &nRoof), body = mean("red_truck", &nBody);
    const double grass = mean("grass", &nGrass), face = mean("flesh", &nFace);
    std::printf(
        "vehicle-drive-lwir frame 10, brightness temperature: hood %.1f K (%d px), "
        "tailpipe %.1f K (%d px), roof %.1f K (%d px), body %.1f K (%d px), face %.1f K "
        "(%d px), grass %.1f K (%d px)\n",
        hood, nHood, pipe, nPipe, roof, nRoof, body, nBody, face, nFace, grass, nGrass);
    ASSERT_GT(nHood, 50);
    ASSERT_GT(nRoof, 50);
    ASSERT_GT(nBody, 50);
    ASSERT_GT(nFace, 3);
    EXPECT_GT(hood, body + 5.0);
    EXPECT_GT(hood, roof + 10.0);
    EXPECT_LT(roof, body);
    EXPECT_GT(face, grass + 5.0);
    // The tailpipe, at the rear, is out of sight from the front: its classes hold the material's
    // fixed 393.15 K (config/thermal/materials.toml, [exhaust]).
    EXPECT_EQ(nPipe, 0) << pipe;
    const int tailpipe = sr->scene().materialIndex("tailpipe");
    int pipeClasses = 0;
    for (std::size_t i = 0; i < thermal->surfaces().size(); ++i) {
        if (thermal->surfaces()[i].material != tailpipe) continue;
        EXPECT_NEAR(thermal->temperatures().at(i, sr->scenario().utcStart_unix_s + t_s), 393.15,
                    0.01);
        ++pipeClasses;
    }
    EXPECT_GT(pipeClasses, 0);
}

}  // namespace
}  // namespace nvs::rt
