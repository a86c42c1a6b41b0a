// The replaceable global allocation functions ([new.delete], C++20 §17.6.3), counting each
// call in nvs::rt::bench::detail::gAllocations and otherwise doing what the library's do:
// malloc/aligned_alloc, std::bad_alloc (or nullptr for the nothrow forms) when there is no
// memory. Linked into nvstim and the allocation tests only (an object library: a static
// archive member that defines only operator new might not be pulled in). No library counts
// allocations without replacing these functions, and glibc's malloc hooks are gone (glibc
// 2.34), so this is written here.
//
// Not built under AddressSanitizer: its own operator new checks new/delete pairing, which a
// replacement would switch off; allocationCounting() then stays false.

#include <cstdlib>
#include <new>

#include "rt/bench/alloc_count.h"

// GCC defines __SANITIZE_ADDRESS__; clang answers __has_feature(address_sanitizer).
#if defined(__SANITIZE_ADDRESS__)
#define NVS_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define NVS_ASAN 1
#endif
#endif

#if !defined(NVS_ASAN)

namespace {

struct MarkCounting {
    MarkCounting() { nvs::rt::bench::detail::gCounting.store(true); }
} gMarkCounting;

void* allocate(std::size_t n) noexcept {
    nvs::rt::bench::detail::gAllocations.fetch_add(1, std::memory_order_relaxed);
    return std::malloc(n == 0 ? 1 : n);
}

void* allocateAligned(std::size_t n, std::align_val_t al) noexcept {
    nvs::rt::bench::detail::gAllocations.fetch_add(1, std::memory_order_relaxed);
    const auto a = static_cast<std::size_t>(al);
    // aligned_alloc wants a size that is a multiple of the alignment (C11 7.22.3.1).
    const std::size_t size = n == 0 ? a : (n + a - 1) / a * a;
    return std::aligned_alloc(a, size);
}

void* orThrow(void* p) {
    if (p == nullptr) throw std::bad_alloc();
    return p;
}

}  // namespace

void* operator new(std::size_t n) {
    return orThrow(allocate(n));
}
void* operator new[](std::size_t n) {
    return orThrow(allocate(n));
}
void* operator new(std::size_t n, const std::nothrow_t&) noexcept {
    return allocate(n);
}
void* operator new[](std::size_t n, const std::nothrow_t&) noexcept {
    return allocate(n);
}
void* operator new(std::size_t n, std::align_val_t al) {
    return orThrow(allocateAligned(n, al));
}
void* operator new[](std::size_t n, std::align_val_t al) {
    return orThrow(allocateAligned(n, al));
}
void* operator new(std::size_t n, std::align_val_t al, const std::nothrow_t&) noexcept {
    return allocateAligned(n, al);
}
void* operator new[](std::size_t n, std::align_val_t al, const std::nothrow_t&) noexcept {
    return allocateAligned(n, al);
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
void operator delete(void* p, const std::nothrow_t&) noexcept {
    std::free(p);
}
void operator delete[](void* p, const std::nothrow_t&) noexcept {
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
void operator delete(void* p, std::align_val_t, const std::nothrow_t&) noexcept {
    std::free(p);
}
void operator delete[](void* p, std::align_val_t, const std::nothrow_t&) noexcept {
    std::free(p);
}

#endif
