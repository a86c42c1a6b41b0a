#pragma once
// The thermal side of a rendered scene (docs/thermal.md, "Rendering"): the scene's surface
// classes (the renderer groups faces by material, orientation and sky-view factor), each with
// its thermal material (the scene material's `thermal` name in the thermal library), its Sun-
// shadow history (shadow rays toward the Sun every `shadowStep_s` through the weather history),
// the heat balance over that history (sim/thermal, cached), and the night's LWIR table
// (sim/lwir, cached). Per frame: the surface temperatures at the instant, as the renderer's
// ThermalFrame. Setup throws SetupError naming file:line; per frame nothing allocates.

#include <filesystem>
#include <memory>
#include <vector>

#include "rt/compose/scene_setup.h"
#include "sim/astro/ephemeris.h"
#include "sim/astro/time.h"
#include "sim/core/paths.h"
#include "sim/lwir/lwir_table.h"
#include "sim/render/renderer.h"
#include "sim/scene/scene.h"
#include "sim/thermal/heat_balance.h"
#include "sim/thermal/material.h"
#include "sim/thermal/weather.h"

namespace nvs::rt {

struct ThermalSceneSpec {
    std::filesystem::path weatherFile;    // the weather history (sim/thermal/weather.h)
    std::filesystem::path materialsFile;  // the thermal materials (config/thermal/materials.toml)
    lwir::BandResponse band = lwir::BandResponse::flat(7.5, 13.5);
    double pressure_Pa = 101325.0;
    thermal::HeatBalanceParams heat;
    double shadowStep_s = 1800.0;  // Sun shadows through the history, every this many seconds
};

class ThermalScene {
  public:
    // Classes from `renderer` (its scene as placed now: moving objects at their current pose);
    // temperatures tabulated over [start_s, end_s] (POSIX UTC seconds); `epoch` is the
    // AstroTime of POSIX second epoch_s (the Sun's position for the shadows).
    ThermalScene(const scene::Scene& scene, render::Renderer& renderer, const astro::Site& site,
                 const astro::AstroTime& epoch, double epoch_s, double start_s, double end_s,
                 const ThermalSceneSpec& spec, const DataDirs& dirs);

    // The renderer's inputs at t_s (POSIX UTC seconds). No allocation, no throw.
    const render::ThermalFrame& frame(double t_s) noexcept;
    // The band radiance of the ground a surface sees besides the sky at t_s: the open,
    // upward-facing classes' radiance weighted by their area (the air's where the scene has
    // none). No allocation, no throw.
    double groundRadianceAt(double t_s) const noexcept;

    const std::vector<render::ThermalSurface>& surfaces() const { return surfaces_; }
    const std::vector<thermal::SurfaceClass>& classes() const { return classes_; }
    const thermal::SurfaceTemperatureTable& temperatures() const { return table_; }
    const lwir::LwirTable& lwirTable() const { return *lwir_; }
    const thermal::WeatherSeries& weather() const { return weather_; }
    const thermal::HeatBalanceReport& report() const { return report_; }

    // The thermal side of a scenario with a thermal camera preset: its [thermal] table, the
    // preset's band, the scene as placed at the start, the heat balance over the run (at least
    // a minute, the table's span). What the run and the bench both set up.
    static std::unique_ptr<ThermalScene> forScenario(ScenarioRenderer& sr, const DataDirs& dirs);
    // The same for a thermal camera `cam` beside the scenario's own camera (its renderer's
    // classes; Renderer::setThermalView then draws the thermal camera from shared hits).
    static std::unique_ptr<ThermalScene> forChannel(ScenarioRenderer& sr,
                                                    const bolometer::ThermalCameraParams& cam,
                                                    const ThermalSpec& ts, const DataDirs& dirs);

  private:
    void buildClasses(const scene::Scene& scene, const render::Renderer& renderer,
                      const astro::Site& site, const astro::AstroTime& epoch, double epoch_s,
                      double start_s, double end_s, const ThermalSceneSpec& spec);
    void fillTables();

    thermal::MaterialLibrary library_;
    thermal::WeatherSeries weather_;
    std::vector<render::ThermalSurface> surfaces_;
    std::vector<thermal::SurfaceClass> classes_;
    thermal::SurfaceTemperatureTable table_;
    thermal::HeatBalanceReport report_;
    std::unique_ptr<lwir::LwirTable> lwir_;
    std::vector<float> temperature_K_, emissivity_, blackbody_, tau_, path_, sky_;
    std::vector<std::size_t> groundClasses_;  // open ground: up-facing, sky view > 0.75
    render::ThermalFrame frame_;
};

}  // namespace nvs::rt
