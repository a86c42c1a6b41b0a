// nvstim render SCENARIO --frame K --out FILE.exr: one frame of a scenario as photoelectron
// radiance [pe s⁻¹ m⁻² sr⁻¹] (OpenEXR, one FLOAT channel Y) with the unit, the scenario time and
// the Moon's position in the header; the band radiance ∫Lβ dλ [W m⁻² sr⁻¹] goes next to it as
// FILE.band.exr (docs/design.md §3, §7).

#include <cmath>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/compose/scene_setup.h"
#include "sim/core/error.h"
#include "sim/core/output_file.h"
#include "sim/core/units.h"
#include "sim/io/exr.h"

namespace nvs::cli {
namespace {

std::string fmt(double v) {
    char b[64];
    std::snprintf(b, sizeof b, "%.9g", v);
    return b;
}

}  // namespace

int runRender(const RenderOptions& opts) {
    if (opts.frame < 0) throw SetupError("--frame: must be ≥ 0");
    const std::filesystem::path out = opts.out;
    if (out.extension() != ".exr") throw SetupError("--out " + opts.out + ": must end in .exr");
    std::filesystem::path bandPath = out;
    bandPath.replace_extension(".band.exr");
    // Both outputs checked before any work, against each other and the scenario.
    OutputFiles outputs;
    outputs.addInput(opts.scenario);
    outputs.addFile("--out", out);
    outputs.addFile("--out (band radiance)", bandPath);
    auto sr = rt::ScenarioRenderer::create(opts.scenario, resolveDataDirs());
    outputs.addInput(sr->scenario().file);
    const double t_s = sr->frameTime_s(opts.frame);
    // The ephemeris and the sky tables hold over the scenario's longest duration.
    if (!(t_s <= rt::kMaxDuration_s)) {
        throw SetupError("--frame " + std::to_string(opts.frame) + ": " + fmt(t_s) +
                         " s after the scenario's start, beyond the limit of " +
                         fmt(rt::kMaxDuration_s) + " s");
    }
    const auto& cam = sr->renderer().camera();
    ImageF pe(cam.width, cam.height), band(cam.width, cam.height);
    rt::ThreadExecutor ex;
    if (sr->scenario().primaryVisibility != render::PrimaryVisibility::kEmbree) {
        std::fprintf(stderr, "nvstim render: %s\n",
                     sr->renderer().choosePrimaryVisibility(ex).c_str());
    }
    sr->renderFrame(t_s, pe.view(), band.view(), ex);

    const auto& moon = sr->sunMoon().moon;
    std::vector<std::pair<std::string, std::string>> attrs = {
        {"nvstim.scenario", sr->scenario().file},
        {"nvstim.frame", std::to_string(opts.frame)},
        {"nvstim.utc_start", sr->scenario().utcStart},
        {"nvstim.t_s", fmt(t_s)},
        {"nvstim.camera", sr->scenario().camera.preset},
        {"nvstim.moon_alt_deg", fmt(moon.alt_rad * kDegPerRad)},
        {"nvstim.moon_az_deg", fmt(moon.az_rad * kDegPerRad)},
    };
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
