#include "sim/core/cpu_isa.h"

#include <array>

#include "sim/core/error.h"

namespace nvs {

namespace {

// From the lowest level to the highest; each includes the ones before it.
constexpr std::array<const char*, 5> kLevels = {"sse2", "sse4.2", "avx", "avx2", "avx512"};

int levelIndex(const std::string& isa) {
    for (std::size_t i = 0; i < kLevels.size(); ++i)
        if (isa == kLevels[i]) return static_cast<int>(i);
    return -1;
}

int hostLevel() {
#if defined(__x86_64__) && defined(__GNUC__)
    __builtin_cpu_init();
    // The groups Embree's dispatcher requires for each of its kernel sets (embree
    // common/sys/sysinfo.h: SSE42 = SSE4.1 + SSE4.2 over SSE3; AVX2 = AVX + AVX2 + FMA3 + BMI1/2
    // + LZCNT; AVX512 = AVX2 + F + DQ + CD + BW + VL).
    const bool sse42 = __builtin_cpu_supports("sse4.2") && __builtin_cpu_supports("sse4.1");
    const bool avx = sse42 && __builtin_cpu_supports("avx");
    const bool avx2 = avx && __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma") &&
                      __builtin_cpu_supports("bmi") && __builtin_cpu_supports("bmi2");
    const bool avx512 = avx2 && __builtin_cpu_supports("avx512f") &&
                        __builtin_cpu_supports("avx512dq") && __builtin_cpu_supports("avx512cd") &&
                        __builtin_cpu_supports("avx512bw") && __builtin_cpu_supports("avx512vl");
    return avx512 ? 4 : avx2 ? 3 : avx ? 2 : sse42 ? 1 : 0;
#else
    return -1;
#endif
}

}  // namespace

std::string hostIsa() {
#if defined(__x86_64__)
    return kLevels[static_cast<std::size_t>(hostLevel())];
#elif defined(__aarch64__)
    return "aarch64";
#else
    return "unknown";
#endif
}

bool hostHasIsa(const std::string& isa) {
    const int i = levelIndex(isa);
    return i >= 0 && i <= hostLevel();
}

std::string embreeDeviceConfig(const std::string& isa) {
    if (isa.empty()) return "";
    if (levelIndex(isa) < 0) {
        throw SetupError(std::string(kEmbreeIsaEnv) + ": '" + isa +
                         "' is not one of sse2, sse4.2, avx, avx2, avx512 (unset: Embree's "
                         "choice)");
    }
    if (!hostHasIsa(isa)) {
        throw SetupError(std::string(kEmbreeIsaEnv) + ": this CPU has no " + isa +
                         " (its best is " + hostIsa() + ")");
    }
    return "isa=" + isa;
}

std::string embreeIsa(const std::string& isa) {
    return isa.empty() ? hostIsa() : isa;
}

}  // namespace nvs
