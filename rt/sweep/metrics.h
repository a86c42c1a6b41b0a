#pragma once
// What a job of kind run measures (docs/sweep.md, "Results"): from its frames, the camera's
// digital counts as `nvstim run --output pgm:DIR` writes them (the counts as they are, the
// header's maximum value the ADC's top code 2^bits - 1, sim/io/pnm.h), and from its --stats
// JSON.
//   frames            frames read
//   mean_counts       mean of every pixel of every frame [counts]
//   std_counts        their standard deviation (population, divided by n) [counts]
//   p99_counts        the smallest count that at least 99 % of the pixels are at or under
//   adc_top           the ADC's top code (the PGM maximum value)
//   adc_top_fraction  the fraction of pixels at the top code (clipped)
//   frames_fnv        FNV-1a (sim/core/fnv.h) of every sample as 16-bit little-endian, in
//                     frame, row and column order: equal digests, equal frames
//   frames_emitted, sink_errors, frame_time_mean_s   the --stats JSON's frames_emitted,
//                     sink_errors and frame_time.mean_s

#include <filesystem>
#include <string>
#include <vector>

#include "rt/sweep/json.h"

namespace nvs::rt::sweep {

// The metrics' names in the results' column order; timing ones are marked by timingColumn().
const std::vector<std::string>& runMetricNames();
bool timingColumn(const std::string& name);

// Measures the frames of `framesDir` (*.pgm in name order) and reads `statsFile`; returns the
// metrics as an object. Throws SetupError naming the file that cannot be read.
Json measureRun(const std::filesystem::path& framesDir, const std::filesystem::path& statsFile);

}  // namespace nvs::rt::sweep
