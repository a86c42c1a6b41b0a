#pragma once
// The model's noise again with the mean effects found, and the choice between two members of
// an effect that share the mean and differ in the noise (docs/diagnose.md, "Protection's
// member", "Persistence's member").

#include <cstdint>
#include <filesystem>
#include <vector>

#include "sim/fit/diagnose.h"
#include "sim/fit/effects.h"
#include "sim/fit/model.h"

namespace nvs::fit {

// m.noisy again with the findings' preset keys (halo, glare and saturation on the stimulus);
// with `lagInLight` the mean model's persistence acts on each frame's light, not in the
// phosphor.
void resimulateNoise(const Dataset& d, ModelRun& m, const Work& w, const MeanModel& mm,
                     const std::vector<Finding>& found, const std::filesystem::path& configDir,
                     std::uint64_t seed, bool lagInLight = false);

// A named protection's member (gain or photoelectrons) and a named persistence's (phosphor or
// light), each chosen by the excess-noise test; m.noisy ends as the chosen member's.
void chooseBspMember(const Dataset& d, ModelRun& m, Work& w, const Current& cur,
                     const std::filesystem::path& configDir, const Options& opt,
                     const Progress& progress, Result& r);
void choosePersistenceMember(const Dataset& d, ModelRun& m, Work& w, const Current& cur,
                             const std::filesystem::path& configDir, const Options& opt,
                             const Progress& progress, Result& r);

}  // namespace nvs::fit
