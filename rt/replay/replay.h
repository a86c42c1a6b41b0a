#pragma once
// Deterministic scenario replay with stored expectations (docs/design.md §9, docs/style.md §12–13).
//
// A scenario folder holds scenario.toml and, after `--bless`, expected/:
//   expected/digest.toml       build fingerprint, frame count, SHA-256 of every output frame
//                              and of the metadata stream
//   expected/stats.toml        the statistical reference: frame windows, block size, levels
//   expected/wN_mean.pfm       per block of kBlock×kBlock pixels and window N: mean over the
//   expected/wN_meanvar.pfm    window of the block's per-frame mean, the variance of that
//   expected/wN_pixvar.pfm     per-frame block mean, and the mean temporal per-pixel variance
//
// `--check` replays the scenario (nvstim run --clock sim, which is bit-exact) and compares:
//   1. When the build fingerprint (compiler, architecture, build type, libm and FFTW versions)
//      is the one that blessed, the frames must be bit-identical: any difference fails and
//      names the frames that moved.
//   2. Always, the statistics: per block, a Z-test of the window mean,
//      z = (μ − μ_ref)/√((s²_ref + s²)/n) with s² the variance of the per-frame block mean
//      (which carries the spatial correlation the MTF gives the noise), and the ratio of the
//      per-pixel temporal variance. A block fails when |z| > 5 (and the mean moved by more
//      than half a count) or its noise variance moved by more than 25 %; and over the whole
//      window, a Z-test of the mean shift of all blocks (|z| > 6) and the ratio of the mean
//      noise variance (more than 3 % off), which catch a change of a few percent in gain or
//      noise that no single block shows. On another machine this is the whole check.
// On failure, z-maps and mean-difference images are written to DIR/check-failures/ and one
// readable line per moved statistic is printed.

#include <filesystem>
#include <string>
#include <vector>

namespace nvs::rt {

struct ReplayResult {
    bool passed = false;
    std::string report;  // human-readable, several lines
};

inline constexpr int kReplayBlock_px = 8;

// The fingerprint of this build: what must match for digests to be comparable. On x86-64,
// "gcc VERSION x86_64+ISA BUILD_TYPE glibc VERSION", ISA as isaFingerprint() names it.
std::string buildFingerprint();

// The instruction-set level this process runs at: the CPU's (sim/core/cpu_isa.h hostIsa, with
// AVX-512 written "avx512f"), followed by "/embree-LEVEL" where NVS_EMBREE_ISA pins Embree to
// a lower one.
std::string isaFingerprint();

// A fingerprint with its ISA left out: two runs whose fingerprints agree here differ only in
// the CPU's (or Embree's) instruction set.
std::string fingerprintWithoutIsa(const std::string& fingerprint);

// A new private folder under $TMPDIR (mkdtemp: mode 0700, a name no other run can have): two
// replays at once never share one. --check and --bless remove theirs; plain replay keeps it.
std::filesystem::path makeReplayTempDir();

// Runs the scenario in `dir` with `nvstimExe run --clock sim` into `workDir` (frames/,
// meta.jsonl, run.log) and returns the frames' folder. Throws SetupError on a bad folder or a
// failed run. The child runs with SIGCHLD and SIGPIPE at their defaults, and is waited for
// even when this process ignores SIGCHLD.
std::filesystem::path replayScenario(const std::filesystem::path& dir,
                                     const std::filesystem::path& nvstimExe,
                                     const std::filesystem::path& workDir);

// A rig's channel names ([[channel]] name, in order); empty for a single camera. A rig replays
// each channel into WORK/CHANNEL/{frames/, meta.jsonl} and keeps its expectations in
// expected/CHANNEL/ (replayScenario then returns WORK).
std::vector<std::string> rigChannels(const std::filesystem::path& dir);

// Replays and writes expected/ (bless), or compares against it (check). --bless writes only a
// real expected/ folder inside `dir` (a symbolic link is an error) and removes only the files
// it writes itself. --check fails closed: an empty or inconsistent digest list, a window outside
// the run, a non-finite reference are errors naming file:line (SetupError), never a pass.
void blessScenario(const std::filesystem::path& dir, const std::filesystem::path& nvstimExe);
ReplayResult checkScenario(const std::filesystem::path& dir,
                           const std::filesystem::path& nvstimExe);

}  // namespace nvs::rt
