// The shipped FFTW wisdom (config/fftw/wisdom-single.txt) holds plans every x86-64 CPU can
// use: SSE2 codelets and scalar ones only. A plan with AVX or AVX-512 codelets is not found on a
// CPU without them, which then plans another way and blurs to other bits (docs/portability.md;
// the wisdom is made as a Nehalem CPU under qemu-user, docs/sensor.md).

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <string>

namespace {

TEST(ShippedWisdom, UsesOnlyCodeletsEveryX86_64CpuHas) {
    std::ifstream in(NVS_SOURCE_DIR "/config/fftw/wisdom-single.txt");
    ASSERT_TRUE(in.good());
    const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    // FFTW's codelet names end in their SIMD set: _sse2, _avx, _avx2, _avx2_128, _avx_128_fma,
    // _avx512, _kcvi, _altivec, _neon, _vsx, _generic_simd128/256; scalar codelets have none.
    const std::regex codelet("fftwf_codelet_([A-Za-z0-9_]+)");
    const std::regex simd("_(avx[0-9a-z_]*|kcvi|altivec|neon|vsx|generic_simd[0-9]+)$");
    int codelets = 0, sse2 = 0;
    for (std::sregex_iterator it(text.begin(), text.end(), codelet), end; it != end; ++it) {
        const std::string name = (*it)[1];
        ++codelets;
        if (name.size() > 5 && name.compare(name.size() - 5, 5, "_sse2") == 0) ++sse2;
        EXPECT_FALSE(std::regex_search(name, simd)) << name;
    }
    EXPECT_GT(codelets, 10);
    EXPECT_GT(sse2, 0);  // the plans do use SIMD: SSE2's
}

}  // namespace
