#pragma once
// The x86-64 instruction-set level this process runs on, and the level Embree is pinned to.
//
// nvstim runs on every x86-64 CPU. Its own SIMD code picks a version at load time (GCC
// target_clones for x86-64-v4 / AVX2 / baseline, hand-written AVX-512 kernels with a probe), and
// every version gives the same bits (docs/portability.md). Embree picks its kernel set the same
// way; RenderConfig::embreeIsa pins it to a lower one so that each set can be tested on one
// machine. The runtime takes the pin from the environment (sim/ reads none):
//
//   NVS_EMBREE_ISA   sse2 | sse4.2 | avx | avx2 | avx512   (unset or empty: Embree's choice,
//                    the best the CPU has). A set the CPU lacks is a setup error.

#include <string>

namespace nvs {

// The best level of the running CPU, by name: "avx512" (AVX-512 F, CD, BW, DQ, VL: Embree's
// avx512 set and GCC's x86-64-v4), "avx2" (AVX2 + FMA + BMI2: x86-64-v3), "avx", "sse4.2",
// "sse2". On other architectures, the architecture's name.
std::string hostIsa();

// Whether the running CPU has the named level (one of the names above).
bool hostHasIsa(const std::string& isa);

// The one probe of nvstim's hand-written AVX-512 kernels (sim/core/rng.cpp, gamma_table.cpp,
// sim/sensor/stages/phosphor.cpp): hostHasIsa("avx512"), asked once and kept, so that a row
// loop may ask it per call. Every kernel gives the same bits as its portable form.
inline bool hostHasAvx512() noexcept {
    static const bool has = hostHasIsa("avx512");
    return has;
}

// The environment variable the runtime reads the pin from.
inline constexpr const char* kEmbreeIsaEnv = "NVS_EMBREE_ISA";

// Embree's device configuration for a pin: "" for none (its own choice), else "isa=NAME".
// Throws SetupError for a name not in the list or a level this CPU lacks.
std::string embreeDeviceConfig(const std::string& pinnedIsa);

// The level Embree's kernels run at under a pin: the pin if set, else hostIsa().
std::string embreeIsa(const std::string& pinnedIsa);

}  // namespace nvs
