#include "rt/compose/scene_setup.h"

#include <algorithm>
#include <cstdlib>
#include <thread>
#include <vector>

#include "rt/compose/environment.h"
#include "sim/core/cpu_isa.h"
#include "sim/sensor/mtf.h"
#include "sim/sky/frame_sky.h"
#include "sim/sky/night_sky.h"
#include "sim/sky/stars.h"

namespace nvs::rt {

using namespace render;

RenderConfig renderConfigFor(const sensor::CameraParams& cam, int width, int height) {
    RenderConfig c;
    c.camera.width = width;
    c.camera.height = height;
    c.camera.focalLength_m = cam.focal_length_mm * 1e-3;
    c.camera.pitchX_m = sensor::cathodePitchX_mm(cam) * 1e-3;
    c.camera.pitchY_m = sensor::cathodePitchY_mm(cam) * 1e-3;
    // A scenario may ask for a different image size than the preset's; keep the field of view
    // of the preset's sensor.
    c.camera.pitchX_m *= static_cast<double>(cam.width) / width;
    c.camera.pitchY_m *= static_cast<double>(cam.height) / height;
    const Spectrum beta = sensor::cameraResponse(cam);
    c.bandWeight[kBandPe] = sky::photoelectronWeight(beta * cam.qe_peak);
    c.bandWeight[kBandW] = beta;
    // Embree's kernel set, pinned from the environment for tests of each set (cpu_isa.h).
    c.embreeIsa = embreeIsaPin();
    return c;
}

RenderConfig thermalRenderConfig(const bolometer::ThermalCameraParams& cam, double focalLength_mm,
                                 int width, int height) {
    RenderConfig c;
    c.camera.width = width;
    c.camera.height = height;
    c.camera.focalLength_m = focalLength_mm * 1e-3;
    // The focal-plane array's pitch; another image size keeps the array's field of view.
    c.camera.pitchX_m = cam.pitch_um * 1e-6 * cam.width / width;
    c.camera.pitchY_m = cam.pitch_um * 1e-6 * cam.height / height;
    // The visible bands are not rendered for a thermal camera (renderThermal draws the frame);
    // the renderer's setup still needs weights.
    const Spectrum one = Spectrum::fromFunction([](double) { return 1.0; });
    c.bandWeight[kBandPe] = sky::photoelectronWeight(one);
    c.bandWeight[kBandW] = one;
    c.embreeIsa = embreeIsaPin();
    return c;
}

void ThreadExecutor::run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept {
    const int n = std::max(1, std::min(8, static_cast<int>(std::thread::hardware_concurrency())));
    std::vector<std::thread> ts;
    for (int i = 1; i < n; ++i)
        ts.emplace_back([=] { fn(ctx, rows * i / n, rows * (i + 1) / n); });
    fn(ctx, 0, rows / n);
    for (auto& t : ts)
        t.join();
}

std::unique_ptr<ScenarioRenderer> ScenarioRenderer::create(const std::filesystem::path& path,
                                                           const DataDirs& dirs, int coarseFactor) {
    return create(loadScenario(path, dirs.config), dirs, coarseFactor);
}

std::unique_ptr<ScenarioRenderer> ScenarioRenderer::create(const Scenario& sc, const DataDirs& dirs,
                                                           int coarseFactor) {
    if (!sc.rendered) throw SetupError(sc.file + ": the scenario has no [scene] to render");
    auto r = std::unique_ptr<ScenarioRenderer>(new ScenarioRenderer());
    r->scenario_ = sc;
    const SceneSpec& spec = sc.scene;
    r->scene_ = scene::loadScene(spec.sceneFile);
    if (spec.lampsOn) {
        for (auto& l : r->scene_.lamps)
            l.on = false;
        for (const std::string& name : *spec.lampsOn) {
            const int i = r->scene_.lampIndex(name);
            if (i < 0)
                throw SetupError(sc.file + ": [scene] lamps_on: unknown lamp '" + name + "'");
            r->scene_.lamps[static_cast<std::size_t>(i)].on = true;
        }
    }
    r->ephemeris_ = std::make_unique<astro::Ephemeris>(spec.site);
    r->epoch_ = astro::astroTimeFromUtc(astro::parseIsoUtc(sc.utcStart, sc.file + ": utc_start"),
                                        sc.file + ": utc_start");
    RenderConfig cfg;
    if (sc.camera.thermal) {
        r->camera_ = sc.camera.params;
        cfg = thermalRenderConfig(*sc.camera.thermalParams, spec.thermal->focalLength_mm, sc.width,
                                  sc.height);
    } else {
        // The sensor as designed (the scenario's size may differ: renderConfigFor keeps its
        // field of view).
        r->camera_ = sensor::loadCamera(dirs.config, sc.camera.preset, sc.camera.presetOverrides);
        cfg = renderConfigFor(r->camera_, sc.width, sc.height);
    }
    cfg.coarseFactor = coarseFactor;
    cfg.primaryVisibility = sc.primaryVisibility;
    sky::SkyModelConfig skyConfig;
    skyConfig.atmosphere = spec.atmosphere;
    skyConfig.extraBands.push_back({"render_pe", cfg.bandWeight[kBandPe]});
    skyConfig.extraBands.push_back({"render_W", cfg.bandWeight[kBandW]});
    r->sky_ = std::make_unique<sky::SkyModel>(sky::SkyModel::create(skyConfig, dirs));
    r->tableBand_ = {r->sky_->table().bandIndex("render_pe"),
                     r->sky_->table().bandIndex("render_W")};
    cfg.moonShape = r->sky_->moon().referenceIrradiance_W_m2_nm();
    const sky::NightSkyModel night = sky::NightSkyModel::load(dirs.config);
    cfg.nightSkyShape = night.measured_W_m2_sr_nm();
    r->renderer_ = std::make_unique<Renderer>(r->scene_, cfg);
    r->stars_ = sky::loadStarCatalog(sky::starCatalogPath(dirs.config));
    if (r->stars_.size() > static_cast<std::size_t>(kMaxStars)) {
        throw SetupError(r->stars_.file + ": more than " + std::to_string(kMaxStars) + " stars");
    }
    const Photometry photometry(dirs.config);
    for (int b = 0; b < kBands; ++b) {
        r->starBandPerLux_[static_cast<std::size_t>(b)] = sky::bandPerLux(
            photometry, cfg.bandWeight[static_cast<std::size_t>(b)], sky::kStarTemperature_K);
    }
    r->starAz_.assign(r->stars_.size(), 0.0);
    r->starAlt_.assign(r->stars_.size(), 0.0);
    return r;
}

FrameSky ScenarioRenderer::prepare(double t_s) noexcept {
    const astro::AstroTime t = epoch_.plusSeconds(t_s);
    // ERFA's context for this instant, built once for the Moon and the stars.
    const astro::AstrometryContext astrometry = ephemeris_->prepare(t);
    sunMoon_ = ephemeris_->compute(astrometry);
    renderer_->setTime(t_s);
    FrameSky s =
        sky::frameSky(*sky_, tableBand_, sunMoon_.moon, t_s, scenario_.scene.lunarSkyScale);
    // Stars above the horizon, with their band irradiance at the lens (sim/sky/stars.h).
    ephemeris_->stars(astrometry, stars_.ra_rad.data(), stars_.dec_rad.data(),
                      static_cast<int>(stars_.size()), starAz_.data(), starAlt_.data());
    sky::frameStars(stars_, starAz_.data(), starAlt_.data(), starBandPerLux_, sky_->table(),
                    tableBand_, &s);
    return s;
}

void ScenarioRenderer::renderFrame(double t_s, ImageView<float> pe, ImageView<float> bandW,
                                   render::RowExecutor& exec, int rowParity) noexcept {
    const FrameSky sky = prepare(t_s);
    renderer_->render(sky, pe, bandW, exec, rowParity);
}

}  // namespace nvs::rt
