// The phosphor's binary16 store: the portable conversions give the x86 instructions' values bit
// for bit, and the portable and AVX-512 phosphor rows the same output and store, so that the
// chain's output does not depend on the CPU.

#include "sim/sensor/half.h"

#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdint>
#include <vector>

#include "sim/sensor/chain.h"

#if defined(__x86_64__) && defined(__GNUC__)
#include <immintrin.h>
namespace {
__attribute__((target("f16c"))) std::uint16_t hardwareHalf(float v) {
    return static_cast<std::uint16_t>(_cvtss_sh(v, _MM_FROUND_TO_NEAREST_INT | _MM_FROUND_NO_EXC));
}
__attribute__((target("f16c"))) float hardwareFloat(std::uint16_t h) {
    return _cvtsh_ss(h);
}
}  // namespace

TEST(Half, ConversionsAreTheInstructionsBitForBit) {
    __builtin_cpu_init();
    if (!__builtin_cpu_supports("f16c")) GTEST_SKIP() << "no F16C on this CPU";
    using nvs::sensor::floatFromHalf;
    using nvs::sensor::halfFromFloat;
    // Every binary16 value back to float, and every tie and its neighbours (the rounding's
    // hard cases): the float halfway between each pair of neighbouring half values, ± 1 ulp.
    for (std::uint32_t h = 0; h < 0x7C00u; ++h) {
        const auto hh = static_cast<std::uint16_t>(h);
        ASSERT_EQ(std::bit_cast<std::uint32_t>(floatFromHalf(hh)),
                  std::bit_cast<std::uint32_t>(hardwareFloat(hh)))
            << h;
        if (h + 1 == 0x7C00u) continue;  // the next is infinity: no midpoint (the sweep has it)
        const float mid =
            0.5f * (hardwareFloat(hh) + hardwareFloat(static_cast<std::uint16_t>(h + 1)));
        for (int d = -1; d <= 1; ++d) {
            const float v = std::bit_cast<float>(std::bit_cast<std::uint32_t>(mid) + d);
            ASSERT_EQ(halfFromFloat(v), hardwareHalf(v)) << v;
        }
    }
    // A sweep through every float from 0 to 65536 (every 97th bit pattern), subnormal halves
    // and the values that round to infinity included.
    for (std::uint32_t f = 0; f <= 0x47800000u; f += 97u) {
        const float v = std::bit_cast<float>(f);
        ASSERT_EQ(halfFromFloat(v), hardwareHalf(v)) << f;
    }
}
#endif

TEST(Half, PhosphorRowsPortableAndVectorAgree) {
    if (!nvs::sensor::detail::phosphorHasAvx512()) GTEST_SKIP() << "no AVX-512 on this CPU";
    // Three stored components, a row of 773 pixels (a partial last block), 20 periods of a
    // random excitation spanning 12 decades; the store's scales as boundInput makes them.
    const int w = 773, m = 3;
    const int blocks = (w + 15) / 16;
    std::vector<std::uint16_t> sa(static_cast<std::size_t>(blocks) * 16 * m, 0), sb = sa;
    std::vector<float> in(w), oa(w), ob(w);
    const float k[3] = {0.17f, 0.33f, 0.26f}, dc[3] = {0.0f, 2.4e-4f, 0.72f};
    const float em[3] = {1.0f, 0.99976f, 0.28f};
    const float scale[3] = {64.0f, 128.0f, 512.0f}, inv[3] = {1 / 64.0f, 1 / 128.0f, 1 / 512.0f};
    std::uint64_t x = 88172645463325252ull;
    for (int period = 0; period < 20; ++period) {
        for (int i = 0; i < w; ++i) {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            const double u = static_cast<double>(x >> 11) * 0x1p-53;
            in[static_cast<std::size_t>(i)] =
                (x & 7) == 0 ? 0.0f : static_cast<float>(std::pow(10.0, 12.0 * u - 8.0));
        }
        nvs::sensor::detail::phosphorRowHalf(in.data(), oa.data(), sa.data(), w, m, 0.4f, k, dc, em,
                                             scale, inv);
        nvs::sensor::detail::phosphorRowHalfAvx512(in.data(), ob.data(), sb.data(), w, m, 0.4f, k,
                                                   dc, em, scale, inv);
        for (int i = 0; i < w; ++i)
            ASSERT_EQ(std::bit_cast<std::uint32_t>(oa[static_cast<std::size_t>(i)]),
                      std::bit_cast<std::uint32_t>(ob[static_cast<std::size_t>(i)]))
                << period << " " << i;
        ASSERT_EQ(sa, sb) << period;
    }
}
