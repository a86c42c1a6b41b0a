#include "sim/fit/generate_scene.h"

#include <cstdio>
#include <fstream>
#include <random>

#include "sim/core/error.h"
#include "sim/core/gamma_table.h"
#include "sim/fit/text.h"
#include "sim/sensor/chain.h"

namespace nvs::fit {

namespace {

// The RIT site (thesis Figure 5-8 scene node file; ground 0.218 km, Figure 5-9).
constexpr double kSiteLat_deg = 43.16856, kSiteLon_deg = -77.61583, kSiteHeight_m = 218.0;

}  // namespace

const std::vector<EffectRange>& sceneEffectRanges() {
    static const std::vector<EffectRange> r = {
        {"lunar_sky_scatter", "lunar_sky_scale", 0.5, 2.0},
        {"refraction", "pressure_hPa", 700.0, 1050.0},
        {"cloud_transmission", "cloud_optical_depth", 0.3, 3.0},
        {"aerosol_extinction", "visibility_km", 35.0, 100.0},
    };
    return r;
}

SceneSetup sceneSetupFor(const std::string& effect) {
    SceneSetup s;
    if (effect == "refraction") {
        // The Moon's disk in view as it sets: the camera on the roof (the scene camera's
        // 15.6 m) looking west-south-west at the horizon, one frame every 20 s from 05:57 UTC
        // (the Moon 2.0° up at azimuth 241°) to 06:13 (its upper limb on the horizon, azimuth
        // 244°; `nvstim ephem`). The dataset's 128 × 96 pixels of 18 µm at the photocathode see
        // 3.7° × 3.3° through the 36 mm lens; refraction lifts the disk (18 px across) by
        // 0.3–0.5° there, 10–17 px, and delays its setting by minutes.
        s.utcStart = "1998-09-02T05:57:00Z";
        s.framePeriod_s = 20.0;
        // The Moon's disk in view: 3.62 V gives the 0.267 DC per photoelectron that 4 V gave
        // before the tube's gain was re-anchored (docs/validation.md, "Tube gain"), so the disk
        // stays below the ADC's top.
        s.gain_V = 3.62;
        s.posed = true;
        s.cameraHeight_m = 15.6;
        s.yaw_deg = 242.5;
        s.pitch_deg = 1.0;
    } else if (effect == "cloud_transmission") {
        // A whole night under the full Moon (Table 9-1's 97 % Moon, 1998-09-06): from 01:00 UTC
        // (Sun −15°, Moon rising at 15.5°) over its culmination (37.5° at 05:00) to 09:22 (Moon
        // 12° in the west), one frame every 640 s. Both halves of the dataset see the Moon's
        // air mass change (3.7 → 1.6 and 1.6 → 4.8): the cloud's e^(−τm) in the calibration
        // half is not a constant factor that the camera's gain absorbs.
        s.utcStart = "1998-09-06T01:00:00Z";
        s.framePeriod_s = 640.0;
        s.gain_V = 5.0;  // the full Moon high: the clear-sky frames stay below the ADC's top
    } else if (effect == "aerosol_extinction") {
        // The rising Moon (90 %, 1998-09-09, `nvstim ephem`): from 01:27 UTC (2.6° up, air mass
        // 16.6, Sun −20°) to 04:30 (34°, 1.8), one frame every 229 s. The visibility is fitted
        // on the calibration half, which here spans air mass 12.5 → 3.3 (frames 2–23): the
        // setting Moon's calibration half (23° → 14°, 2.5 → 4.1) left 20 % of a visibility near
        // 80 km at about 2 % of the frames' light, and 1 of 9 seeds came back 24 % high.
        s.utcStart = "1998-09-09T01:27:00Z";
        s.framePeriod_s = 229.0;
        s.gain_V = 5.0;  // the Moon brighter and higher than the setting Moon's 23°
    }
    return s;
}

void writeSceneScenario(const std::filesystem::path& file, const std::filesystem::path& sceneFile,
                        const SkyEffects& fx, const SceneSetup& setup) {
    std::ofstream t(file);
    t << "# The RIT roof under the Moon (written for a diagnose dataset)\n"
      << "[scenario]\nname = \"diagnose-scene\"\nutc_start = \"" << setup.utcStart
      << "\"\nframe_rate_hz = 29.97\n\n"
      << "[site]\nlat_deg = " << tomlNumber(kSiteLat_deg)
      << "\nlon_deg = " << tomlNumber(kSiteLon_deg) << "\nheight_m = " << tomlNumber(kSiteHeight_m)
      << "\n"
      << "pressure_hPa = " << tomlNumber(fx.pressure_hPa) << "\n\n"
      << "[atmosphere]\nvisibility_km = " << tomlNumber(fx.visibility_km)
      << "\naerosol = \"rural\"\n"
      << "cloud_optical_depth = " << tomlNumber(fx.cloudOpticalDepth) << "\n"
      << "lunar_sky_scale = " << tomlNumber(fx.lunarSkyScale) << "\n\n"
      << "[camera]\npreset = \"pulnix-ag5745ef3\"\n\n";
    if (setup.posed) {
        t << "[platform]\nlat_deg = " << tomlNumber(kSiteLat_deg)
          << "\nlon_deg = " << tomlNumber(kSiteLon_deg)
          << "\nalt_m = " << tomlNumber(kSiteHeight_m + setup.cameraHeight_m)
          << "\nyaw_deg = " << tomlNumber(setup.yaw_deg)
          << "\npitch_deg = " << tomlNumber(setup.pitch_deg) << "\n\n";
    }
    t << "[scene]\nfile = \"" << std::filesystem::absolute(sceneFile).generic_string()
      << "\"\nlamps_on = [";
    for (std::size_t i = 0; i < setup.lampsOn.size(); ++i)
        t << (i ? ", " : "") << "\"" << setup.lampsOn[i] << "\"";
    t << "]\n";
    if (!t) throw SetupError(file.string() + ": cannot write");
}

void prepareSceneDataset(Dataset& d, const std::string& preset, const sensor::Overrides& settings,
                         int width, int height, int frames, double framePeriod_s,
                         const SceneStimulusFactory& factory,
                         const std::filesystem::path& configDir) {
    d.preset = preset;
    d.settings = settings;
    d.camera = loadModelCamera(configDir, d.preset, d.settings, d.cameraExtra);
    d.presetFile = sensor::resolveCameraPath(configDir, d.preset);
    d.width = width;
    d.height = height;
    d.frameRate_Hz = 1.0 / framePeriod_s;
    d.frameMax_dc = (1 << d.camera.adc_bits) - 1;
    d.unit = "pe/s/m2/sr";
    for (int k = 0; k < frames; ++k) {
        d.frameNumbers.push_back(k);
        d.stimulusOfFrame.push_back(k);
    }
    d.scene = factory(d.scenario, d.camera, d.presetFile, d.settings);
}

Generated generateScene(const SceneGenSpec& s, const SceneStimulusFactory& factory,
                        const std::filesystem::path& configDir) {
    Generated g;
    Dataset& d = g.data;
    std::mt19937_64 rng(s.seed * 0x9E3779B97F4A7C15ull + 0x5ce7e5ull);
    // The truth: the physics (lunar sky light, refraction at standard pressure, no cloud) with
    // the hidden effect's strength drawn; the model: the same without the effect.
    SkyEffects truth, model;
    const double u = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
    for (const EffectRange& e : sceneEffectRanges()) {
        if (s.effect != e.effect) continue;
        const double v = e.lo + u * (e.hi - e.lo);
        g.truth[std::string(e.effect) + "." + e.parameter] = v;
        if (s.effect == "lunar_sky_scatter") {
            truth.lunarSkyScale = v;
            model.lunarSkyScale = 0.0;
        } else if (s.effect == "refraction") {
            truth.pressure_hPa = v;
            model.pressure_hPa = 0.0;
        } else if (s.effect == "aerosol_extinction") {
            truth.visibility_km = v;  // the model keeps the scenario's 23 km
        } else {
            truth.cloudOpticalDepth = v;
        }
    }
    if (!s.effect.empty() && g.truth.empty())
        throw SetupError("no scenario effect '" + s.effect + "'");
    std::filesystem::create_directories(s.workDir);
    d.scenario = s.workDir / "scenario.toml";
    const SceneSetup setup = sceneSetupFor(s.effect);
    writeSceneScenario(d.scenario, s.sceneFile, model, setup);
    prepareSceneDataset(d, "pulnix-ag5745ef3",
                        {{"width", std::to_string(s.width)},
                         {"height", std::to_string(s.height)},
                         {"agc", "\"off\""},
                         {"gain_V", tomlNumber(setup.gain_V)},
                         // The chain's halo and MCP saturation off in the frames and the model
                         // alike: diagnose's own forward models of them are approximations, and the
                         // scenario sweep is about the scene.
                         {"halo.enabled", "false"},
                         {"mcp_saturation.enabled", "false"},
                         // Each frame of a time-lapse is its own exposure: frame scan, so that no
                         // frame holds a field of the one taken minutes before.
                         {"video.scan", "\"frame\""}},
                        s.width, s.height, s.frames, setup.framePeriod_s, factory, configDir);
    d.sceneEffects = d.scene->stated();
    d.stimuli = d.scene->render(d.frameNumbers, d.frameRate_Hz, model, {});
    const std::vector<ImageF> seen = d.scene->render(d.frameNumbers, d.frameRate_Hz, truth, {});
    const sensor::CameraParams cam = sensor::loadCamera(configDir, d.preset, d.settings);
    makeFrames(cam, s.seed, seen, configDir, d);
    return g;
}

}  // namespace nvs::fit
