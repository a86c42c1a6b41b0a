#pragma once
// The stimulus of a measured dataset rendered from a scenario (`[stimulus] scenario`,
// docs/contracts.md "Measured dataset"): diagnose's SceneStimulus (sim/fit/dataset.h) on the
// composition root's ScenarioRenderer. The scenario gives the scene, site, atmosphere and start
// time; the dataset gives the camera (its preset and settings, at the frames' size) and the
// frames' times (frame n at utc_start + n / frame_rate_hz). The camera stands where `nvstim run`
// puts it without telemetry: at the [platform] pose when the scenario states one (the same
// PlatformPose as the render stage), else at the scene's own camera. The scenario effects of the
// catalog are rendered as asked: lunar sky light scaled, refraction by the site pressure, the cloud
// layer's optical depth, the aerosol's extinction by the visibility.

#include <filesystem>
#include <memory>

#include "sim/core/paths.h"
#include "sim/fit/dataset.h"

namespace nvs::rt {

// Throws SetupError (a scenario without a [scene], an unknown camera).
std::unique_ptr<fit::SceneStimulus> makeSceneStimulus(const std::filesystem::path& scenario,
                                                      const sensor::CameraParams& camera,
                                                      const std::filesystem::path& presetFile,
                                                      const sensor::Overrides& settings,
                                                      const DataDirs& dirs);

}  // namespace nvs::rt
