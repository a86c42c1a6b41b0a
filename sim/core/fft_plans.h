#pragma once
// FFTW plans that give the same bits on every x86-64 CPU (docs/portability.md, "The blur's FFT
// plans", which covers both chains): the shipped wisdom (config/fftw/, made by
// tests/sim/sensor/make_wisdom.sh) where it holds the problem, else FFTW_ESTIMATE among FFTW's
// scalar solvers. Used by every FFT of the camera chains: the intensified chain's blur
// (sim/sensor/stages/blur.cpp) and the microbolometer's optics MTF
// (sim/bolometer/stages/optics.cpp).
//
// Setup only: like FFTW's planner these are not thread-safe (chains are made on one thread).

#include <filesystem>
#include <functional>

struct fftwf_plan_s;  // fftw3.h's fftwf_plan is a pointer to it

namespace nvs {

// How a chain plans its FFTs: from the shipped wisdom (the default; bit-exact replay), or
// measured anew (FFTW_MEASURE, FFTW_PATIENT: faster on this CPU, but a measured plan can differ
// from run to run; what the wisdom tool makes the shipped wisdom with).
enum class FftPlanning { Shipped, Measure, Patient };

// FFTW's planner flags for `planning` (fftw3.h's FFTW_*), or-ed with `extra`.
unsigned fftPlannerFlags(FftPlanning planning, unsigned extra = 0);

// Imports <configDir>/fftw/wisdom-single.txt and wisdom-single-sse.txt where they exist (FFTW
// takes the one whose header matches this CPU and rejects the other). An empty configDir
// imports nothing. Importing the same file again replaces each entry with itself, so callers
// import before every plan they make.
void importShippedFftWisdom(const std::filesystem::path& configDir);

// make(flags) with the flags given; where that gives no plan and the flags hold
// FFTW_WISDOM_ONLY, make(FFTW_ESTIMATE | FFTW_NO_SIMD | the flags' FFTW_DESTROY_INPUT).
// Throws SetupError("<what>: FFTW could not plan") if neither gives a plan. *fromFlags (when
// given): whether the plan is the one of the flags asked for (with FFTW_WISDOM_ONLY: from
// wisdom), not the estimate.
fftwf_plan_s* planFromWisdomOrEstimate(const std::function<fftwf_plan_s*(unsigned)>& make,
                                       unsigned flags, const char* what, bool* fromFlags = nullptr);

// Writes the wisdom FFTW's planner holds (every plan made so far in this process) to `file`.
// Returns false if it could not be written.
bool exportFftWisdom(const std::filesystem::path& file);

}  // namespace nvs
