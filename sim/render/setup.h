#pragma once
// Everything a scenario needs to render a frame, set up from its file: the scene, the camera
// preset (band weights, focal length, pixel pitch), the ephemeris and the sky model with the
// camera's two bands, and the renderer. Setup throws SetupError; per frame nothing allocates.

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "sim/astro/ephemeris.h"
#include "sim/astro/time.h"
#include "sim/render/renderer.h"
#include "sim/render/stars.h"
#include "sim/scene/scenario.h"
#include "sim/scene/scene.h"
#include "sim/sensor/camera.h"
#include "sim/sky/sky_model.h"

namespace nvs::render {

// The renderer's camera and band weights from a camera preset: w_pe = QE(λ) λ/(hc) with
// QE = qe_peak β, w_W = β; the pinhole's focal length and the pixel pitch at the photocathode.
RenderConfig renderConfigFor(const sensor::CameraParams& cam, int width, int height);

class ScenarioRenderer {
  public:
    // Data (camera preset, sky, stars) from dirs.config, the atmosphere table cached in
    // dirs.cache.
    static std::unique_ptr<ScenarioRenderer> create(const std::filesystem::path& scenarioPath,
                                                    const DataDirs& dirs, int coarseFactor = 1);

    // Sets the scene to frame k (moving objects, Sun/Moon, stars) and returns the frame's sky.
    // t_s is the time since the scenario epoch. No allocation, no throw.
    FrameSky prepare(double t_s) noexcept;

    Renderer& renderer() { return *renderer_; }
    const scene::RenderScenario& scenario() const { return scenario_; }
    const scene::Scene& scene() const { return scene_; }
    const sensor::CameraParams& camera() const { return camera_; }
    const astro::SunMoonState& sunMoon() const { return sunMoon_; }

  private:
    scene::RenderScenario scenario_;
    scene::Scene scene_;
    sensor::CameraParams camera_;
    std::unique_ptr<astro::Ephemeris> ephemeris_;
    astro::AstroTime epoch_;
    std::unique_ptr<sky::SkyModel> sky_;
    std::array<int, kBands> tableBand_{-1, -1};
    std::unique_ptr<Renderer> renderer_;
    astro::SunMoonState sunMoon_;
    StarCatalog stars_;
    std::array<double, kBands> starBandPerLux_{};
    std::vector<double> starAz_, starAlt_;  // per frame
};

}  // namespace nvs::render
