#pragma once
// IEEE 754 binary16 from and to float without F16C, for the phosphor's afterglow store
// (PhosphorStage::boundInput): the values the x86 conversion instructions give, bit for bit, so
// that a CPU without them makes the same output (tests/sim/sensor/half_test.cpp checks them
// against vcvtps2ph / vcvtph2ps).

#include <bit>
#include <cstdint>

namespace nvs::sensor {

// Round to nearest even, for values in [0, 65520) (larger ones give infinity; negative ones
// and NaN are not handled: the phosphor's stores are ≥ 0 and its scales keep them below 2^14): the
// F16C / AVX-512 vcvtps2ph result, bit for bit (F. Giesen's float_to_half_fast3_rtne, checked
// against the instruction in the tests), for CPUs without AVX-512.
inline std::uint16_t halfFromFloat(float v) noexcept {
    std::uint32_t f = std::bit_cast<std::uint32_t>(v);
    constexpr std::uint32_t kMax = (127u + 16u) << 23;  // 65536
    if (f >= kMax) return 0x7C00u;
    if (f < (113u << 23)) {  // below 2^−14: a subnormal half or zero, rounded by a float add
        constexpr float kMagic = std::bit_cast<float>(((127u - 15u) + (23u - 10u) + 1u) << 23);
        return static_cast<std::uint16_t>(std::bit_cast<std::uint32_t>(v + kMagic) -
                                          std::bit_cast<std::uint32_t>(kMagic));
    }
    const std::uint32_t odd = (f >> 13) & 1u;
    f += ((15u - 127u) << 23) + 0xFFFu + odd;
    return static_cast<std::uint16_t>(f >> 13);
}
inline float floatFromHalf(std::uint16_t h) noexcept {
    const std::uint32_t e = h >> 10, m = h & 0x3FFu;
    if (e == 0) return static_cast<float>(m) * 0x1p-24f;  // subnormal: exact
    return std::bit_cast<float>(((e + 112u) << 23) | (m << 13));
}

}  // namespace nvs::sensor
