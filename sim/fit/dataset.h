#pragma once
// A measured dataset (docs/contracts.md, "Measured dataset"): the folder `nvstim diagnose`
// reads. dataset.toml names the camera preset and its settings, the stimulus (radiance images,
// OpenEXR or PFM, with their unit and spectrum) and the camera's frames (8/16-bit PGM or PNG),
// with optional named regions. Everything is read and checked at load: a frame of another size
// than the stimulus, a missing or out-of-order frame, an unknown preset or a unit that cannot be
// converted is a SetupError naming the file and the problem, before anything is written.

#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "sim/core/image.h"
#include "sim/sensor/camera.h"

namespace nvs::fit {

// Progress lines for the caller to print (stderr in the command line).
using Progress = std::function<void(const std::string&)>;

struct Roi {
    std::string name;
    int x = 0, y = 0, w = 0, h = 0;  // [px]
};

// One frame-sized plane of floats, row-major without padding.
using Plane = std::vector<float>;

// Effects a preset may switch on that the camera chain (sim/sensor) does not implement: diagnose
// applies its own forward models for them (effects.h) so that a preset written by
// --write-preset is the model it describes. Keys as in docs/contracts.md.
struct FitEffects {
    double haloFraction = 0.0, haloRadius_um = 0.0;   // [halo]
    double satCharge_e = 0.0, satRecharge_s = 0.0;    // [mcp_saturation]
    double glareFraction = 0.0, glareScale_um = 0.0;  // [veiling_glare]
};

// Loads a preset (name or path) with overrides; tables the chain rejects as unknown among
// [halo], [mcp_saturation] and [veiling_glare] are read into `extra` instead.
sensor::CameraParams loadModelCamera(const std::filesystem::path& configDir,
                                     const std::string& nameOrPath,
                                     const sensor::Overrides& overrides, FitEffects& extra);

// The scenario effects of the catalog (docs/contracts.md), as a scenario states them: what a
// stimulus rendered from a scenario depends on besides the scene and the ephemeris.
struct SkyEffects {
    double lunarSkyScale = 1.0;      // [atmosphere] lunar_sky_scale (0: no lunar sky light)
    double pressure_hPa = 1013.25;   // [site] pressure_hPa (0: no refraction)
    double cloudOpticalDepth = 0.0;  // [atmosphere] cloud_optical_depth
    double visibility_km = 23.0;     // [atmosphere] visibility_km (aerosol extinction)
};

// A stimulus rendered from a scenario (`[stimulus] scenario`). sim/fit does not render: the
// composition root gives the implementation (rt/compose/scene_stimulus.h).
class SceneStimulus {
  public:
    virtual ~SceneStimulus() = default;
    // The scenario's own values: the model under test.
    virtual SkyEffects stated() const = 0;
    // Photoelectron radiance [pe s⁻¹ m⁻² sr⁻¹] at the camera's size for each dataset frame
    // number n, rendered at the scenario's utc_start + n / frameRate_Hz with `fx`. Throws
    // SetupError.
    virtual std::vector<ImageF> render(const std::vector<long long>& frames, double frameRate_Hz,
                                       const SkyEffects& fx, const Progress& progress) = 0;
    // The Moon's apparent altitude [deg] at frame n with `fx` (for reports).
    virtual double moonAltitude_deg(long long frame, double frameRate_Hz, const SkyEffects& fx) = 0;
};

// Makes the renderer of a scenario stimulus for the dataset's camera (its preset with the
// dataset's settings, at the frames' size); throws SetupError.
using SceneStimulusFactory = std::function<std::unique_ptr<SceneStimulus>(
    const std::filesystem::path& scenario, const sensor::CameraParams& camera,
    const std::filesystem::path& presetFile, const sensor::Overrides& settings)>;

struct Dataset {
    std::filesystem::path dir;
    std::string preset;          // [camera] preset, as written
    sensor::Overrides settings;  // [camera.settings], as preset overrides
    sensor::CameraParams camera;
    FitEffects cameraExtra;  // the preset's effects applied by diagnose's own forward models
    std::filesystem::path presetFile;
    int width = 0, height = 0;
    // The distinct stimulus images, photoelectron radiance Lpe [pe s⁻¹ m⁻² sr⁻¹], and which
    // one each frame saw. Identical files are stored once.
    std::vector<ImageF> stimuli;
    std::vector<int> stimulusOfFrame;
    std::vector<Plane> frames;  // measured frames [DC]
    double frameRate_Hz = 0.0;
    long long firstFrame = 0;
    std::vector<Roi> rois;
    std::string unit;       // of the stimulus files as given
    std::string spectrum;   // for W/m2/sr stimuli
    int frameMax_dc = 255;  // largest value the frame files can hold
    // [stimulus] scenario: the scenario rendered for every frame (stimuli then holds one image
    // per frame), the frames' numbers and the scenario's effects as stated.
    std::filesystem::path scenario;
    std::shared_ptr<SceneStimulus> scene;
    std::vector<long long> frameNumbers;
    SkyEffects sceneEffects;
    std::size_t frameCount() const { return frames.size(); }
};

// Most frames a dataset may have ([output] count, the files found, the list): bounded before
// anything is allocated for them (docs/reliability-inputs.md).
inline constexpr long long kMaxDatasetFrames = 100000;
// Fewest: the chain's 2 warm-up frames, then the first half of the rest calibrates and the
// second half is held out, each needing 2 frames.
inline constexpr long long kMinDatasetFrames = 8;
// Largest frame number (first_frame, a number in a file name): 15 digits.
inline constexpr long long kMaxFrameNumber = 999'999'999'999'999;

// Reads DATASET_DIR/dataset.toml and everything it names; presets from configDir/cameras. A
// scenario stimulus needs `renderScenario` (without it: SetupError).
Dataset loadDataset(const std::filesystem::path& dir, const std::filesystem::path& configDir,
                    const Progress& progress = {}, const SceneStimulusFactory& renderScenario = {});

// Writes a dataset folder in the contract's layout: dataset.toml, radiance/NNNNNN.pfm (one per
// distinct stimulus, unit pe/s/m2/sr) and frames/NNNNNN.pgm. For the generator and the tests.
void writeDataset(const Dataset& d, const std::filesystem::path& dir);

// Reads an 8/16-bit PGM (P5) or PNG frame as DC values.
Plane readFrame(const std::filesystem::path& path, int& width, int& height, int& maxValue);

}  // namespace nvs::fit
