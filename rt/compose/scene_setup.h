#pragma once
// The render side of the composition root: everything a scenario needs to render a frame, set up
// from the loaded scenario — the scene, the camera preset's band weights, focal length and pixel
// pitch, the ephemeris, the sky model with the camera's two bands, the star catalog and the
// renderer — and, per frame, the stages run in order: astro (Sun, Moon, stars at the instant)
// → sky (the frame's sky message, the stars' irradiance: sim/sky) → render (renderFrame). Setup
// throws SetupError; per frame nothing allocates.

#include <array>
#include <filesystem>
#include <memory>
#include <string>
#include <vector>

#include "rt/compose/scenario.h"
#include "sim/astro/ephemeris.h"
#include "sim/astro/time.h"
#include "sim/render/renderer.h"
#include "sim/scene/scene.h"
#include "sim/sensor/camera.h"
#include "sim/sky/sky_model.h"
#include "sim/sky/stars.h"

namespace nvs::rt {

using render::FrameSky;
using render::kBands;
using render::RenderConfig;
using render::Renderer;

// The renderer's camera and band weights from a camera preset: w_pe = QE(λ) λ/(hc) with
// QE = qe_peak β, w_W = β; the pinhole's focal length and the pixel pitch at the photocathode.
RenderConfig renderConfigFor(const sensor::CameraParams& cam, int width, int height);
// The same for a thermal camera: its focal-plane array behind a lens of focal length f.
RenderConfig thermalRenderConfig(const bolometer::ThermalCameraParams& cam, double focalLength_mm,
                                 int width, int height);

// Row ranges on the machine's cores (up to 8), with threads started per call: for commands that
// render a frame at a time outside the frame loop (render, diagnose); the loop has its RowPool.
class ThreadExecutor final : public render::RowExecutor {
  public:
    void run(int rows, void (*fn)(void*, int, int), void* ctx) noexcept override;
};

class ScenarioRenderer {
  public:
    // A rendered scenario (one with a [scene]); throws SetupError otherwise. Data (camera
    // preset, sky, stars) from dirs.config, the atmosphere table cached in dirs.cache.
    static std::unique_ptr<ScenarioRenderer> create(const Scenario& scenario, const DataDirs& dirs,
                                                    int coarseFactor = 1);
    // The same from the scenario's file (rt/compose/scenario.h loads it).
    static std::unique_ptr<ScenarioRenderer> create(const std::filesystem::path& scenarioPath,
                                                    const DataDirs& dirs, int coarseFactor = 1);

    // Sets the scene to frame k (moving objects, Sun/Moon, stars) and returns the frame's sky.
    // t_s is the time since the scenario epoch. No allocation, no throw.
    FrameSky prepare(double t_s) noexcept;
    // The frame at t_s: prepare(t_s), then the renderer's render with its sky (both bands;
    // rowParity 0 or 1: an interlaced field's own rows, Renderer::render). Every caller that
    // renders a scenario's frame goes through here. No allocation, no throw.
    void renderFrame(double t_s, ImageView<float> pe, ImageView<float> bandW,
                     render::RowExecutor& exec, int rowParity = -1) noexcept;

    Renderer& renderer() { return *renderer_; }
    const Renderer& renderer() const { return *renderer_; }
    // The lunar sky light of the frames prepared from now on ([atmosphere] lunar_sky_scale).
    void setLunarSkyScale(double scale) { scenario_.scene.lunarSkyScale = scale; }
    const Scenario& scenario() const { return scenario_; }
    // Seconds since the scenario epoch of frame k (its start, at the scenario's frame rate).
    double frameTime_s(long long frame) const {
        return static_cast<double>(frame) / scenario_.rate.hz();
    }
    const scene::Scene& scene() const { return scene_; }
    const sensor::CameraParams& camera() const { return camera_; }
    // The AstroTime of the scenario's start (utc_start).
    const astro::AstroTime& epoch() const { return epoch_; }
    const astro::SunMoonState& sunMoon() const { return sunMoon_; }
    const sky::SkyModel& sky() const { return *sky_; }
    // The atmosphere table's band of each renderer band.
    const std::array<int, kBands>& tableBands() const { return tableBand_; }

  private:
    Scenario scenario_;
    scene::Scene scene_;
    sensor::CameraParams camera_;
    std::unique_ptr<astro::Ephemeris> ephemeris_;
    astro::AstroTime epoch_;
    std::unique_ptr<sky::SkyModel> sky_;
    std::array<int, kBands> tableBand_{-1, -1};
    std::unique_ptr<Renderer> renderer_;
    astro::SunMoonState sunMoon_;
    sky::StarCatalog stars_;
    std::array<double, kBands> starBandPerLux_{};
    std::vector<double> starAz_, starAlt_;  // per frame
};

}  // namespace nvs::rt
