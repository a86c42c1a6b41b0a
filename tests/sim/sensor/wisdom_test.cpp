// The shipped FFTW wisdom (config/fftw/, sim/sensor/chain.cpp, docs/portability.md): the same
// plans under the two headers FFTW knows on x86-64 (CPUs with and without AVX), naming only
// codelets every x86-64 CPU has (SSE2 and scalar). Wisdom naming AVX codelets gives a CPU
// without AVX no plan, and a file under one header only is rejected whole by the other CPUs:
// either way that CPU plans otherwise and blurs to other bits (seen: a few pixels one count
// apart under qemu as Nehalem-v2). This guards the files against an export made the usual way.

#include <gtest/gtest.h>

#include <fstream>
#include <regex>
#include <string>

namespace {

std::string readFile(const char* name) {
    std::ifstream in(std::string(NVS_SOURCE_DIR "/config/fftw/") + name);
    return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

TEST(ShippedWisdom, TheSameSse2PlansUnderBothHeaders) {
    const std::string avx = readFile("wisdom-single.txt"), sse = readFile("wisdom-single-sse.txt");
    ASSERT_FALSE(avx.empty());
    ASSERT_FALSE(sse.empty());
    const std::size_t a = avx.find('\n'), s = sse.find('\n');
    ASSERT_NE(a, std::string::npos);
    ASSERT_NE(s, std::string::npos);
    EXPECT_NE(avx.substr(0, a), sse.substr(0, s));  // two headers
    EXPECT_EQ(avx.substr(a), sse.substr(s));        // one set of plans
    // FFTW's codelet names end in their SIMD set: _sse2, _avx, _avx2, _avx2_128, _avx_128_fma,
    // _avx512, _kcvi, _altivec, _neon, _vsx, _generic_simd128/256; scalar codelets have none.
    const std::regex codelet("fftwf_codelet_([A-Za-z0-9_]+)");
    const std::regex other("_(avx[0-9a-z_]*|kcvi|altivec|neon|vsx|generic_simd[0-9]+)$");
    const std::regex sse2("_sse2$");
    int codelets = 0, simd = 0;
    for (std::sregex_iterator it(sse.begin(), sse.end(), codelet), end; it != end; ++it) {
        const std::string name = (*it)[1];
        ++codelets;
        EXPECT_FALSE(std::regex_search(name, other)) << name;
        if (std::regex_search(name, sse2)) ++simd;
    }
    EXPECT_GT(codelets, 10);
    EXPECT_GT(simd, 0);  // the plans use SIMD: SSE2's
}

}  // namespace
