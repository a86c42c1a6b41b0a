// Scenario stimuli of measured datasets (rt/compose/scene_stimulus.h, sim/fit/scene_effects.h):
// the renderer's lunar sky light is linear in its scale (what the fit relies on), refraction
// raises the Moon as Bennett's formula says, the visibility's extinction of the moonlight
// follows Beer–Lambert, a scenario's [platform] pose is rendered as the runtime renders it, a
// dataset with `[stimulus] scenario` round-trips and refuses bad input, and hidden scenario
// effects are named and recovered (a few seeds; the sweep is `make validate`).
#include "rt/compose/scene_stimulus.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include "rt/compose/scenario.h"
#include "rt/compose/scene_setup.h"
#include "rt/render_stage/render_stage.h"
#include "rt/synth/synth.h"
#include "sim/astro/ephemeris.h"
#include "sim/astro/time.h"
#include "sim/core/error.h"
#include "sim/fit/diagnose.h"
#include "sim/fit/generate_scene.h"
#include "sim/sky/sky_model.h"

namespace nvs::fit {
namespace {

namespace fs = std::filesystem;
const fs::path kSource = NVS_SOURCE_DIR;
const DataDirs kDirs{kSource / "config", fs::path(NVS_BINARY_DIR) / "nvstim-cache"};

fs::path tempDir(const std::string& name) {
    const fs::path p = fs::path(NVS_BINARY_DIR) / "test-scene" / name;
    fs::remove_all(p);
    fs::create_directories(p);
    return p;
}

SceneStimulusFactory factory() {
    return [](const fs::path& sc, const sensor::CameraParams& cam, const fs::path& preset,
              const sensor::Overrides& settings) {
        return rt::makeSceneStimulus(sc, cam, preset, settings, kDirs);
    };
}

SceneGenSpec spec(const std::string& effect, std::uint64_t seed, const fs::path& work) {
    SceneGenSpec s;
    s.effect = effect;
    s.seed = seed;
    s.width = 128;
    s.height = 96;
    s.frames = 48;
    s.sceneFile = kSource / "scenarios" / "rit" / "scene.toml";
    s.workDir = work;
    return s;
}

double meanOf(const ImageF& img) {
    double s = 0.0;
    for (int y = 0; y < img.height(); ++y)
        for (int x = 0; x < img.width(); ++x)
            s += static_cast<double>(img(x, y));
    return s / (img.width() * img.height());
}

TEST(SceneStimulus, LunarSkyLightIsLinearInItsScale) {
    const Generated g = generateScene(spec("", 1, tempDir("linear")), factory(), kDirs.config);
    SkyEffects fx = g.data.sceneEffects;
    const std::vector<long long> frames = {0, 30};
    fx.lunarSkyScale = 0.0;
    const auto l0 = g.data.scene->render(frames, g.data.frameRate_Hz, fx, {});
    fx.lunarSkyScale = 1.0;
    const auto l1 = g.data.scene->render(frames, g.data.frameRate_Hz, fx, {});
    fx.lunarSkyScale = 0.4;
    const auto lh = g.data.scene->render(frames, g.data.frameRate_Hz, fx, {});
    for (std::size_t i = 0; i < frames.size(); ++i) {
        // The lunar sky adds light everywhere in this moonlit scene.
        EXPECT_GT(meanOf(l1[i]), 1.05 * meanOf(l0[i])) << i;
        const double predicted = meanOf(l0[i]) + 0.4 * (meanOf(l1[i]) - meanOf(l0[i]));
        EXPECT_NEAR(meanOf(lh[i]), predicted, 1e-4 * predicted) << i;
    }
}

// Bennett (1982), J. Navigation 35: R = cot(h + 7.31/(h + 4.4)) arcmin at 1010 hPa, 10 °C, for
// the apparent altitude h in degrees. Table 10-1 of the thesis shows the same step between
// ephem (refracted) and make_adb (geometric): 10.00 vs 9.91 deg, 8.39 vs 8.29 deg.
TEST(SceneStimulus, RefractionRaisesTheMoonAsBennettsFormula) {
    const fs::path dir = tempDir("refraction");
    SkyEffects fx;
    SceneSetup setup;
    setup.utcStart = "1998-09-07T01:00:00Z";
    writeSceneScenario(dir / "scenario.toml", kSource / "scenarios" / "rit" / "scene.toml", fx,
                       setup);
    const sensor::CameraParams cam =
        sensor::loadCamera(kDirs.config, "pulnix-ag5745ef3", {{"width", "32"}, {"height", "24"}});
    auto s = rt::makeSceneStimulus(dir / "scenario.toml", cam,
                                   sensor::resolveCameraPath(kDirs.config, "pulnix-ag5745ef3"),
                                   {{"width", "32"}, {"height", "24"}}, kDirs);
    // 01:00 UTC (Table 10-1: 9 PM EDT, ephem 10.00 deg) and 11:00 UTC (7 AM EDT, 8.39 deg).
    for (long long frame : {0LL, 10LL}) {
        SkyEffects airless = fx;
        airless.pressure_hPa = 0.0;
        const double rate = 1.0 / 3600.0;
        const double h = s->moonAltitude_deg(frame, rate, fx);
        const double h0 = s->moonAltitude_deg(frame, rate, airless);
        const double bennett_deg = 1.0 / std::tan((h + 7.31 / (h + 4.4)) * M_PI / 180.0) / 60.0;
        EXPECT_NEAR(h - h0, bennett_deg * (1013.25 / 1010.0) * (283.0 / 288.0), 0.1 * bennett_deg)
            << "frame " << frame << " h " << h;
    }
}

// Kasten & Young (1989): the relative air mass at apparent altitude h [deg].
double airMass(double h_deg) {
    return 1.0 / (std::sin(h_deg * M_PI / 180.0) + 0.50572 * std::pow(h_deg + 6.07995, -1.6364));
}

// The visibility's extinction follows Beer–Lambert along the Moon's slant path: between
// visibilities V1 and V2 the aerosol's vertical optical depth at 550 nm differs by
// Δτ = 3.912·H·(1/V1 − 1/V2) (Koschmieder, aerosol scale height H = 1.2 km; the molecules'
// share cancels), so the direct moonlight changes by e^(Δτ·m), m the Moon's air mass (in the
// photopic band, centred near 555 nm, Δτ within a few per cent of 550 nm's). The sky model the
// renderer uses does so; the rendered scene changes with the visibility by a factor that is not
// the same over the night (the aerosol also scatters moonlight into the sky): not a gain.
TEST(SceneStimulus, VisibilityDimsTheLowMoonByItsAirMass) {
    astro::Site site;
    site.lat_deg = 43.16856;
    site.lon_deg = -77.61583;
    site.height_m = 218.0;
    sky::SkyModelConfig cfg;
    cfg.atmosphere.siteAltitude_m = site.height_m;
    cfg.atmosphere.visibility_km = 23.0;
    const sky::SkyModel hazySky = sky::SkyModel::create(cfg, kDirs);
    cfg.atmosphere.visibility_km = 80.0;
    const sky::SkyModel clearSky = sky::SkyModel::create(cfg, kDirs);
    const double dTau550 = 3.912 * 1.2 * (1.0 / 23.0 - 1.0 / 80.0);
    astro::MoonState moon =
        astro::Ephemeris(site)
            .compute(astro::astroTimeFromUtc(astro::parseIsoUtc("1998-09-02T03:00:00Z")))
            .moon;
    // From 5° up: lower, the sky model's refraction of the path (a few tenths of a degree) moves
    // the air mass by more than the tolerance.
    for (double h_deg : {40.0, 23.0, 10.0, 5.0}) {
        moon.alt_rad = h_deg * M_PI / 180.0;
        const double ratio = clearSky.horizontal(sky::SkyModel::kLuxBand, moon).moonDirect /
                             hazySky.horizontal(sky::SkyModel::kLuxBand, moon).moonDirect;
        EXPECT_NEAR(std::log(ratio) / airMass(h_deg), dTau550, 0.05 * dTau550) << h_deg;
    }
    // The rendered scene of the setting Moon (23° to 1.6°): the change is not one factor.
    const Generated g = generateScene(spec("", 1, tempDir("visibility")), factory(), kDirs.config);
    SkyEffects hazy = g.data.sceneEffects, clear = hazy;
    ASSERT_DOUBLE_EQ(hazy.visibility_km, 23.0);  // the scenario's
    clear.visibility_km = 80.0;
    const std::vector<long long> frames = {0, 24, 40, 46};
    const auto l23 = g.data.scene->render(frames, g.data.frameRate_Hz, hazy, {});
    const auto l80 = g.data.scene->render(frames, g.data.frameRate_Hz, clear, {});
    double lo = 1e300, hi = 0.0;
    for (std::size_t i = 0; i < frames.size(); ++i) {
        const double r = meanOf(l80[i]) / meanOf(l23[i]);
        lo = std::min(lo, r);
        hi = std::max(hi, r);
    }
    EXPECT_GT(hi / lo, 1.1);
}

TEST(SceneStimulus, DatasetRoundTripAndBadInput) {
    const fs::path dir = tempDir("roundtrip");
    const Generated g = generateScene(spec("", 2, dir / "work"), factory(), kDirs.config);
    writeDataset(g.data, dir / "data");
    const Dataset d = loadDataset(dir / "data", kDirs.config, {}, factory());
    ASSERT_EQ(d.stimuli.size(), g.data.stimuli.size());
    EXPECT_EQ(d.frameNumbers, g.data.frameNumbers);
    EXPECT_DOUBLE_EQ(meanOf(d.stimuli[7]), meanOf(g.data.stimuli[7]));
    // Without a renderer, with both stimuli, with a missing scenario: one error naming the key.
    EXPECT_THROW(loadDataset(dir / "data", kDirs.config), SetupError);
    const fs::path toml = dir / "data" / "dataset.toml";
    std::string text;
    {
        std::ifstream in(toml);
        text.assign(std::istreambuf_iterator<char>(in), {});
    }
    std::ofstream(toml) << [&] {
        std::string t = text;
        t.replace(t.find("[stimulus]\n"), 11, "[stimulus]\nradiance = \"r/{frame:06d}.pfm\"\n");
        return t;
    }();
    try {
        loadDataset(dir / "data", kDirs.config, {}, factory());
        ADD_FAILURE() << "both stimuli accepted";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("not both"), std::string::npos) << e.what();
    }
    std::ofstream(toml) << [&] {
        std::string t = text;
        const auto p = t.find("scenario = \"");
        t.replace(p, t.find('\n', p) - p, "scenario = \"nowhere/scenario.toml\"");
        return t;
    }();
    try {
        loadDataset(dir / "data", kDirs.config, {}, factory());
        ADD_FAILURE() << "missing scenario accepted";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("dataset.toml:"), std::string::npos) << e.what();
        EXPECT_NE(std::string(e.what()).find("not found"), std::string::npos) << e.what();
    }
}

// A scenario whose [platform] states a pose: the RIT roof at 64 x 48, the camera on the roof
// turned toward (yaw_deg, pitch_deg).
fs::path posedScenario(const fs::path& dir, double yaw_deg, double pitch_deg) {
    SceneSetup setup;
    setup.utcStart = "1998-09-02T05:30:00Z";
    setup.posed = true;
    setup.cameraHeight_m = 15.6;
    setup.yaw_deg = yaw_deg;
    setup.pitch_deg = pitch_deg;
    SkyEffects fx;
    writeSceneScenario(dir / "scenario.toml", kSource / "scenarios" / "rit" / "scene.toml", fx,
                       setup);
    std::ifstream in(dir / "scenario.toml");
    std::string text(std::istreambuf_iterator<char>(in), {});
    // The runtime's camera is the preset with the dataset's settings: the same 64 x 48 pixels.
    text.replace(text.find("[platform]"), 0, "set = [\"width=64\", \"height=48\"]\n\n");
    std::ofstream(dir / "scenario.toml") << text;
    return dir / "scenario.toml";
}

std::unique_ptr<SceneStimulus> stimulusOf(const fs::path& scenario) {
    const sensor::Overrides size = {{"width", "64"}, {"height", "48"}};
    return rt::makeSceneStimulus(
        scenario, sensor::loadCamera(kDirs.config, "pulnix-ag5745ef3", size),
        sensor::resolveCameraPath(kDirs.config, "pulnix-ag5745ef3"), size, kDirs);
}

// The stimulus of a scenario with a [platform] pose is what `nvstim run` renders for it: the
// runtime's render stage fed by the held platform (no telemetry), at the same time.
TEST(SceneStimulus, PlatformPoseRendersAsTheRuntime) {
    const fs::path sc = posedScenario(tempDir("posed"), 240.5, 2.5);
    const rt::Scenario scenario = rt::loadScenario(sc, kDirs.config);
    ASSERT_TRUE(scenario.platform.poseFromTelemetry);
    // A [platform] with camera settings only keeps the scene's own camera.
    EXPECT_FALSE(
        rt::loadScenario(kSource / "scenarios" / "thesis-nolight" / "scenario.toml", kDirs.config)
            .platform.poseFromTelemetry);
    auto stage = rt::SceneRenderStage::create(scenario, kDirs);
    rt::HeldPlatform held(scenario.platform);
    auto stim = stimulusOf(sc);
    const double rate_Hz = 1.0 / 60.0;
    const long long n = 12;
    const ImageF mine = stim->render({n}, rate_Hz, stim->stated(), {}).front();
    ImageF lpe(64, 48), band(64, 48);
    msg::FrameRequest req;
    held.sample(static_cast<double>(n) / rate_Hz, 0.0, req.platform);
    ASSERT_TRUE(req.platform.poseFromTelemetry);
    msg::FrameMeta meta;
    stage->render(req, msg::RadianceTarget{lpe.view(), band.view()}, meta);
    // The stage takes the time as (utc_start + t) − utc_start: equal to t within rounding.
    double peak = 0.0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x) {
            EXPECT_NEAR(mine(x, y), lpe(x, y),
                        1e-5 * std::fabs(static_cast<double>(lpe(x, y))) + 1e-30)
                << x << "," << y;
            peak = std::max(peak, static_cast<double>(lpe(x, y)));
        }
    EXPECT_GT(peak, 0.0);
}

// Turned to where the ephemeris puts the Moon, the camera has the Moon's disk at the centre of
// its image: the pose (position, yaw, pitch, the camera looking along body x) and the sky agree.
TEST(SceneStimulus, CameraTurnedToTheMoonSeesItsDiskAtTheCentre) {
    const fs::path dir = tempDir("moon-centre");
    // 1998-09-02 05:42 UTC (frame 12 of a minute apart from 05:30): the ephemeris's apparent
    // azimuth and altitude, from a first scenario looking anywhere.
    auto r = rt::ScenarioRenderer::create(posedScenario(dir, 240.0, 2.0), kDirs);
    r->prepare(12 * 60.0);
    const double az_deg = r->sunMoon().moon.az_rad * 180.0 / M_PI;
    const double alt_deg = r->sunMoon().moon.alt_rad * 180.0 / M_PI;
    ASSERT_GT(alt_deg, 2.0);
    auto stim = stimulusOf(posedScenario(dir, az_deg, alt_deg));
    const ImageF img = stim->render({12}, 1.0 / 60.0, stim->stated(), {}).front();
    double sx = 0.0, sy = 0.0, sw = 0.0, peak = 0.0;
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x)
            peak = std::max(peak, static_cast<double>(img(x, y)));
    for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x)
            if (static_cast<double>(img(x, y)) > 0.5 * peak) {
                sx += x + 0.5;
                sy += y + 0.5;
                sw += 1.0;
            }
    ASSERT_GT(sw, 0.0);
    // The disk is 0.52° across, about 17 px at this size (64 pixels of 18 µm at the
    // photocathode behind the 36 mm lens: 1.8°).
    EXPECT_NEAR(sx / sw, 32.0, 1.0);
    EXPECT_NEAR(sy / sw, 24.0, 1.0);
}

// Hidden scenario effects: the top finding names the effect and recovers its strength within
// 20 %; the null dataset gives no scenario finding.
void expectNamed(const std::string& effect, std::uint64_t seed) {
    const Generated g = generateScene(spec(effect, seed, tempDir(effect)), factory(), kDirs.config);
    const Result r = diagnose(g.data, kDirs.config);
    ASSERT_FALSE(r.findings.empty()) << effect << " seed " << seed;
    const Finding& f = r.findings.front();
    ASSERT_EQ(f.effect, effect) << "seed " << seed;
    for (const auto& [k, v] : g.truth)
        for (const auto& [pk, pv] : f.parameters)
            if (k == effect + "." + pk) {
                EXPECT_NEAR(pv, v, 0.2 * v) << k << " seed " << seed;
            }
}

TEST(SceneStimulus, HiddenLunarSkyScatterIsNamed) {
    expectNamed("lunar_sky_scatter", 3);
}

// The Moon's disk setting in view (generate_scene.cpp): refraction moves it by 10–17 px.
TEST(SceneStimulus, HiddenRefractionIsNamed) {
    expectNamed("refraction", 3);
}

TEST(SceneStimulus, HiddenCloudTransmissionIsNamed) {
    expectNamed("cloud_transmission", 3);
}

// The rising Moon (2.6° to 34°) under clearer air than the scenario's 23 km.
TEST(SceneStimulus, HiddenAerosolExtinctionIsNamed) {
    expectNamed("aerosol_extinction", 3);
}

TEST(SceneStimulus, NullDatasetHasNoScenarioFinding) {
    const Generated g = generateScene(spec("", 4, tempDir("null")), factory(), kDirs.config);
    const Result r = diagnose(g.data, kDirs.config);
    for (const Finding& f : r.findings)
        EXPECT_TRUE(f.effect != "lunar_sky_scatter" && f.effect != "refraction" &&
                    f.effect != "cloud_transmission" && f.effect != "aerosol_extinction")
            << f.effect;
}

}  // namespace
}  // namespace nvs::fit
