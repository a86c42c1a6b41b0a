#include "sim/core/fft_plans.h"

#include <fftw3.h>

#include <string>

#include "sim/core/error.h"
#include "sim/core/input_file.h"

namespace nvs {

// Why these plans (measured on an AVX2 CPU against qemu-user as Nehalem-v2 and Haswell-v4,
// tests/isa and tests/sim/bolometer): two facts of FFTW shape them.
// - A plan names codelets, and wisdom that names AVX codelets gives no plan on a CPU without
//   AVX: the shipped plans are made as a CPU with SSE4.2 only (qemu-user, -cpu Nehalem-v2), so
//   they use SSE2 codelets, which every x86-64 CPU has.
// - FFTW takes a wisdom file only when its header's hash of the solvers registered matches the
//   running CPU's, and CPUs with AVX register other solvers than CPUs without: the same plans
//   ship twice, under each header (wisdom-single.txt for CPUs with AVX, wisdom-single-sse.txt
//   for those without).
// Where no wisdom holds the problem (another size), FFTW_ESTIMATE among the scalar solvers
// (FFTW_NO_SIMD): the estimate among SIMD solvers depends on the CPU. Plans from AVX wisdom, or
// SSE2 wisdom under one header only, gave frames a few pixels apart by one count; these give
// identical frames.
// The wisdom lives in FFTW's own planner; importing it again puts back the shipped entries
// should an FFTW_MEASURE plan have replaced one (FFTW's hash table overwrites an entry of the
// same problem and flags).

unsigned fftPlannerFlags(FftPlanning planning, unsigned extra) {
    switch (planning) {
        case FftPlanning::Patient:
            return FFTW_PATIENT | extra;
        case FftPlanning::Measure:
            return FFTW_MEASURE | extra;
        case FftPlanning::Shipped:
            break;
    }
    return FFTW_MEASURE | FFTW_WISDOM_ONLY | extra;
}

void importShippedFftWisdom(const std::filesystem::path& configDir) {
    if (configDir.empty()) return;
    for (const char* name : {"wisdom-single.txt", "wisdom-single-sse.txt"}) {
        const std::filesystem::path file = configDir / "fftw" / name;
        if (pathExists(file)) fftwf_import_wisdom_from_filename(file.c_str());
    }
}

fftwf_plan_s* planFromWisdomOrEstimate(const std::function<fftwf_plan_s*(unsigned)>& make,
                                       unsigned flags, const char* what, bool* fromFlags) {
    fftwf_plan p = make(flags);
    if (fromFlags) *fromFlags = p != nullptr;
    if (!p && (flags & FFTW_WISDOM_ONLY))
        p = make(FFTW_ESTIMATE | FFTW_NO_SIMD | (flags & FFTW_DESTROY_INPUT));
    if (!p) throw SetupError(std::string(what) + ": FFTW could not plan");
    return p;
}

bool exportFftWisdom(const std::filesystem::path& file) {
    return fftwf_export_wisdom_to_filename(file.c_str()) != 0;
}

}  // namespace nvs
