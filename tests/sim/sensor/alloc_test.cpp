// GCC cannot see that the replaced operators below pair malloc with free.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"
// The frame loop allocates nothing: global operator new is replaced in this test binary and
// counts every allocation while fields are processed with every stage on.

#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "sim/sensor/chain.h"
#include "tests/sim/sensor/sensor_test_util.h"

namespace {
std::atomic<long> gAllocations{0};
}  // namespace

void* operator new(std::size_t n) {
    gAllocations.fetch_add(1, std::memory_order_relaxed);
    if (void* p = std::malloc(n == 0 ? 1 : n)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n) {
    return operator new(n);
}
void* operator new(std::size_t n, std::align_val_t a) {
    gAllocations.fetch_add(1, std::memory_order_relaxed);
    const std::size_t al = static_cast<std::size_t>(a);
    if (void* p = std::aligned_alloc(al, (n + al - 1) / al * al)) return p;
    throw std::bad_alloc();
}
void* operator new[](std::size_t n, std::align_val_t a) {
    return operator new(n, a);
}
void operator delete(void* p) noexcept {
    std::free(p);
}
void operator delete[](void* p) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t) noexcept {
    std::free(p);
}
void operator delete(void* p, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete(void* p, std::size_t, std::align_val_t) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::size_t, std::align_val_t) noexcept {
    std::free(p);
}

namespace nvs::sensor {
namespace {

TEST(Allocation, NoneWhileProcessingFields) {
    for (const char* mode : {"off", "agc", "abc", "bsp", "autogate"}) {
        const CameraParams cam = test::preset("pulnix-ag5745ef3", {{"width", "160"},
                                                                   {"height", "120"},
                                                                   {"agc", mode},
                                                                   {"ccd.prnu_rel", "0.05"},
                                                                   {"ccd.smear_rel", "0.01"},
                                                                   {"ccd.dark_e_s", "100"}});
        IiccdChain chain(cam, 9, test::configDir(), test::gammaTables());
        ImageF in = test::uniform(160, 120, 3e11f);
        for (int y = 50; y < 60; ++y)
            for (int x = 70; x < 80; ++x)
                in(x, y) = 1e15f;   // saturates and blooms
        chain.process(in.cview());  // warm-up (nothing lazily allocated either)
        const long before = gAllocations.load();
        for (int k = 0; k < 6; ++k)
            chain.process(in.cview());
        EXPECT_EQ(gAllocations.load() - before, 0) << mode;
    }
}

}  // namespace
}  // namespace nvs::sensor
