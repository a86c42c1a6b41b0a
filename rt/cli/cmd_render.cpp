// nvstim render SCENARIO --frame K --out FILE.exr: one frame of a scenario as photoelectron
// radiance [pe s⁻¹ m⁻² sr⁻¹] (OpenEXR, one FLOAT channel Y) with the unit, the scenario time and
// the Moon's position in the header; the band radiance ∫Lβ dλ [W m⁻² sr⁻¹] goes next to it as
// FILE.band.exr (docs/design.md §3, §7).
// A scenario with a thermal camera preset (docs/bolometer.md, "The command line"): FILE.exr is
// the band radiance at the aperture in the preset's band [W m⁻² sr⁻¹], the one image `nvstim
// sensor --camera PRESET` takes; its header names the preset and the band (nvstim.camera,
// nvstim.band), and the radiance the run's camera faces for its start-up shutter correction
// (nvstim.startup_W_m2_sr). No FILE.band.exr.
// --camera PRESET and --set KEY=VALUE change the scenario's [camera] as `nvstim run`'s do
// (rt::ScenarioOverrides): the render is made for that camera (its size, field of view and
// band), and its header's nvstim.camera names it. A rig takes neither.

#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/compose/scene_setup.h"
#include "rt/compose/thermal_scene.h"
#include "sim/bolometer/camera.h"
#include "sim/core/error.h"
#include "sim/core/output_file.h"
#include "sim/core/units.h"
#include "sim/io/exr.h"
#include "sim/sensor/camera.h"

namespace nvs::cli {
namespace {

std::string fmt(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.9g", v);
    return b;
}

using Attributes = std::vector<std::pair<std::string, std::string>>;

// The header both kinds of render carry (the Sun and Moon as prepared for the frame).
Attributes baseAttributes(const RenderOptions& opts, rt::ScenarioRenderer& sr, double t_s) {
    const auto& moon = sr.sunMoon().moon;
    return {
        {"nvstim.scenario", sr.scenario().file},
        {"nvstim.frame", std::to_string(opts.frame)},
        {"nvstim.utc_start", sr.scenario().utcStart},
        {"nvstim.t_s", fmt(t_s)},
        {"nvstim.camera", sr.scenario().camera.preset},
        {"nvstim.moon_alt_deg", fmt(moon.alt_rad * kDegPerRad)},
        {"nvstim.moon_az_deg", fmt(moon.az_rad * kDegPerRad)},
    };
}

// The thermal camera's frame: the band radiance at the aperture, one file.
int renderThermal(const RenderOptions& opts, rt::ScenarioRenderer& sr, const DataDirs& dirs,
                  double t_s, OutputFiles& outputs) {
    const rt::Scenario& sc = sr.scenario();
    const bolometer::ThermalCameraParams& cam = *sc.camera.thermalParams;
    const std::unique_ptr<rt::ThermalScene> thermal = rt::ThermalScene::forScenario(sr, dirs);
    ImageF band(cam.width, cam.height);
    rt::ThreadExecutor ex;
    (void)sr.prepare(t_s);  // objects and time, as the run's render stage
    sr.renderer().renderThermal(thermal->frame(sc.utcStart_unix_s + t_s), band.view(), ex);
    Attributes attrs = baseAttributes(opts, sr, t_s);
    attrs.push_back({"nvstim.unit", "W/m2/sr"});
    attrs.push_back({"nvstim.band", bolometer::bandName(cam)});
    char start[40];  // exactly the double the run's camera starts from (%.17g round-trips)
    std::snprintf(start, sizeof start, "%.17g", thermal->groundRadianceAt(sc.utcStart_unix_s));
    attrs.push_back({"nvstim.startup_W_m2_sr", start});
    {
        outputs.holdSignals();
        outputs.writeWith(opts.out, [&](const std::filesystem::path& tmp) {
            io::writeExr(tmp, band.cview(), {attrs, {}, {}});
        });
        outputs.commit();
    }
    std::printf(
        "{\"out\":\"%s\",\"frame\":%lld,\"t_s\":%.6f,\"camera\":\"%s\",\"band\":\"%s\","
        "\"surface_classes\":%zu}\n",
        opts.out.c_str(), opts.frame, t_s, sc.camera.preset.c_str(),
        bolometer::bandName(cam).c_str(), thermal->surfaces().size());
    return kExitOk;
}

}  // namespace

int runRender(const RenderOptions& opts) {
    if (opts.frame < 0) throw SetupError("--frame: must be ≥ 0");
    const std::filesystem::path out = opts.out;
    if (out.extension() != ".exr") throw SetupError("--out " + opts.out + ": must end in .exr");
    std::filesystem::path bandPath = out;
    bandPath.replace_extension(".band.exr");
    // The outputs checked before any rendering, against each other and the scenario.
    OutputFiles outputs;
    const DataDirs dirs = resolveDataDirs();
    const std::string scenario = resolveScenario(opts.scenario, scenariosDir(dirs));
    outputs.addInput(scenario);
    outputs.addFile("--out", out);
    rt::ScenarioOverrides overrides;
    overrides.cameraPreset = opts.camera;
    overrides.cameraSets = sensor::parseOverrides(opts.sets);
    auto sr =
        rt::ScenarioRenderer::create(rt::loadScenario(scenario, dirs.config, overrides), dirs);
    outputs.addInput(sr->scenario().file);
    const bool thermal = sr->scenario().camera.thermal;
    if (!thermal) outputs.addFile("--out (band radiance)", bandPath);
    const double t_s = sr->frameTime_s(opts.frame);
    // The ephemeris and the sky tables hold over the scenario's longest duration.
    if (!(t_s <= rt::kMaxDuration_s)) {
        throw SetupError("--frame " + std::to_string(opts.frame) + ": " + fmt(t_s) +
                         " s after the scenario's start, beyond the limit of " +
                         fmt(rt::kMaxDuration_s) + " s");
    }
    if (thermal) return renderThermal(opts, *sr, dirs, t_s, outputs);
    const auto& cam = sr->renderer().camera();
    ImageF pe(cam.width, cam.height), band(cam.width, cam.height);
    rt::ThreadExecutor ex;
    if (sr->scenario().primaryVisibility != render::PrimaryVisibility::kEmbree) {
        std::fprintf(stderr, "nvstim render: %s\n",
                     sr->renderer().choosePrimaryVisibility(ex).c_str());
    }
    sr->renderFrame(t_s, pe.view(), band.view(), ex);

    const auto& moon = sr->sunMoon().moon;
    const Attributes attrs = baseAttributes(opts, *sr, t_s);
    auto peAttrs = attrs;
    peAttrs.push_back({"nvstim.unit", "pe/s/m2/sr"});
    auto bandAttrs = attrs;
    bandAttrs.push_back({"nvstim.unit", "W/m2/sr"});
    bandAttrs.push_back({"nvstim.band", "camera relative response beta"});
    {
        outputs.holdSignals();  // both outputs or none, and no temporary left
        outputs.writeWith(out, [&](const std::filesystem::path& tmp) {
            io::writeExr(tmp, pe.cview(), {peAttrs, {}, {}});
        });
        outputs.writeWith(bandPath, [&](const std::filesystem::path& tmp) {
            io::writeExr(tmp, band.cview(), {bandAttrs, {}, {}});
        });
        outputs.commit();
    }
    const auto& st = sr->renderer().lastStats();
    std::printf(
        "{\"out\":\"%s\",\"band_out\":\"%s\",\"frame\":%lld,\"t_s\":%.6f,\"moon\":{\"alt_deg\":%."
        "4f,"
        "\"az_deg\":%.4f},\"rays\":%llu}\n",
        out.c_str(), bandPath.c_str(), opts.frame, t_s, moon.alt_rad * kDegPerRad,
        moon.az_rad * kDegPerRad, static_cast<unsigned long long>(st.total()));
    return kExitOk;
}

}  // namespace nvs::cli
