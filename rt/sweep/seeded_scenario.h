#pragma once
// How a sweep's seed reaches a run. `nvstim run` has no seed option and no preset key is a
// seed: the noise seed is the scenario's ([scenario] seed, which [camera] seed and each
// [[channel]]'s default follow; rt/compose/scenario.h). So a job with a seed runs a copy of its
// scenario, written into the job's folder:
//   [scenario] seed = S;  [camera] seed = S where the scenario gives one;  a [[channel]]
//   seed, where given, S + i for channel i (the default rule of a rig);
// and, since the copy lies elsewhere, the paths the scenario reads relative to its own folder
// made absolute: [scene] file, [thermal] weather and materials, [telemetry] source = replay:LOG.
// Comments are not copied; everything else is the same TOML.

#include <cstdint>
#include <filesystem>

namespace nvs::rt::sweep {

// Reads the scenario at `from` (a file, or a folder holding scenario.toml) and writes the
// seeded copy to `to`. Throws SetupError naming the scenario (file:line) or `to`.
void writeSeededScenario(const std::filesystem::path& from, std::uint64_t seed,
                         const std::filesystem::path& to);

}  // namespace nvs::rt::sweep
