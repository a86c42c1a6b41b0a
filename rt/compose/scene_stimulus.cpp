#include "rt/compose/scene_stimulus.h"

#include <cmath>
#include <string>

#include "rt/compose/platform_pose.h"
#include "rt/compose/scenario.h"
#include "rt/compose/scene_setup.h"
#include "sim/core/units.h"
#include "sim/fit/text.h"

namespace nvs::rt {
namespace {

class ScenarioStimulus final : public fit::SceneStimulus {
  public:
    ScenarioStimulus(Scenario sc, DataDirs dirs) : base_(std::move(sc)), dirs_(std::move(dirs)) {}

    fit::SkyEffects stated() const override {
        fit::SkyEffects fx;
        fx.lunarSkyScale = base_.scene.lunarSkyScale;
        fx.pressure_hPa = base_.scene.site.pressure_hPa;
        fx.cloudOpticalDepth = base_.scene.atmosphere.cloudOpticalDepth;
        fx.visibility_km = base_.scene.atmosphere.visibility_km;
        return fx;
    }

    std::vector<ImageF> render(const std::vector<long long>& frames, double frameRate_Hz,
                               const fit::SkyEffects& fx, const fit::Progress& progress) override {
        ScenarioRenderer& r = rendererFor(fx, progress);
        const auto& cam = r.renderer().camera();
        std::vector<ImageF> out;
        out.reserve(frames.size());
        ImageF band(cam.width, cam.height);
        ThreadExecutor ex;
        for (long long n : frames) {
            ImageF pe(cam.width, cam.height);
            r.renderFrame(static_cast<double>(n) / frameRate_Hz, pe.view(), band.view(), ex);
            out.push_back(std::move(pe));
        }
        return out;
    }

    double moonAltitude_deg(long long frame, double frameRate_Hz,
                            const fit::SkyEffects& fx) override {
        ScenarioRenderer& r = rendererFor(fx, {});
        r.prepare(static_cast<double>(frame) / frameRate_Hz);
        return r.sunMoon().moon.alt_rad * kDegPerRad;
    }

  private:
    // One renderer, made again when the site pressure, the cloud layer or the visibility
    // changes (the ephemeris and the atmosphere table depend on them; the table is cached on
    // disk).
    ScenarioRenderer& rendererFor(const fit::SkyEffects& fx, const fit::Progress& progress) {
        const bool newAtmosphere = fx.cloudOpticalDepth != made_.cloudOpticalDepth ||
                                   fx.visibility_km != made_.visibility_km;
        if (!current_ || fx.pressure_hPa != made_.pressure_hPa || newAtmosphere) {
            Scenario sc = base_;
            sc.scene.site.pressure_hPa = fx.pressure_hPa;
            sc.scene.atmosphere.cloudOpticalDepth = fx.cloudOpticalDepth;
            sc.scene.atmosphere.visibility_km = fx.visibility_km;
            if (progress && newAtmosphere)
                progress(fit::textf("atmosphere with cloud optical depth %g, visibility %g km",
                                    fx.cloudOpticalDepth, fx.visibility_km));
            current_.reset();
            current_ = ScenarioRenderer::create(sc, dirs_);
            // The camera where the runtime's render stage puts it for the scenario's platform
            // state without telemetry (rt/render_stage): the [platform] pose when it states
            // one, else the scene's own camera.
            if (sc.platform.poseFromTelemetry)
                current_->renderer().setCamera(PlatformPose(sc.scene.site).poseFor(sc.platform));
            made_ = fx;
        }
        current_->setLunarSkyScale(fx.lunarSkyScale);
        return *current_;
    }

    Scenario base_;
    DataDirs dirs_;
    std::unique_ptr<ScenarioRenderer> current_;
    fit::SkyEffects made_;
};

}  // namespace

std::unique_ptr<fit::SceneStimulus> makeSceneStimulus(const std::filesystem::path& scenario,
                                                      const sensor::CameraParams& camera,
                                                      const std::filesystem::path& presetFile,
                                                      const sensor::Overrides& settings,
                                                      const DataDirs& dirs) {
    Scenario sc = loadScenario(scenario, dirs.config);
    if (!sc.rendered) throw SetupError(sc.file + ": the scenario has no [scene] to render");
    if (sc.platform.poseFromTelemetry &&
        !PlatformPose::usable(PlatformPose(sc.scene.site).poseFor(sc.platform)))
        throw SetupError(sc.file + ": the [platform] pose is more than 1e8 m from the site");
    // The dataset's camera: its preset and settings at the frames' size.
    sc.camera.preset = presetFile.string();
    sc.camera.presetOverrides = settings;
    sc.width = camera.width;
    sc.height = camera.height;
    return std::make_unique<ScenarioStimulus>(std::move(sc), dirs);
}

}  // namespace nvs::rt
