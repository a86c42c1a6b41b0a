#pragma once
// A measured dataset folder (docs/contracts.md, "Measured dataset") as `nvstim diagnose` reads
// and diagnoses it, for every caller of the same path: the command line (rt/cli/cmd_diagnose.cpp)
// and the Python module (python/).
//
//   loadDiagnoseDataset   the folder read, a `[stimulus] scenario` rendered through the
//                         composition root (rt/compose/scene_stimulus.h)
//   diagnoseDatasetJson   the folder read and diagnosed: the findings JSON that
//                         `nvstim diagnose DATASET --json OUT` writes (one line, no line end)

#include <cstdint>
#include <filesystem>
#include <string>

#include "sim/core/paths.h"
#include "sim/fit/dataset.h"

namespace nvs::rt {

// Throws SetupError naming the folder or file:line (a bad dataset, as `nvstim diagnose` exits 2).
fit::Dataset loadDiagnoseDataset(const std::filesystem::path& dir, const DataDirs& dirs,
                                 const fit::Progress& progress = {});

// `seed`: the seed of the model's noise (`nvstim diagnose --seed`, default 1). The folder must
// exist ("DIR: not a dataset folder (no such folder)", as the command line says).
std::string diagnoseDatasetJson(const std::filesystem::path& dir, const DataDirs& dirs,
                                std::uint64_t seed = 1, const fit::Progress& progress = {});

}  // namespace nvs::rt
