#pragma once
// A stable 64-bit hash (FNV-1a: xor each byte, multiply by the FNV prime) for cache keys,
// payload checksums and test digests; std::hash is not stable across builds.

#include <cstddef>
#include <cstdint>

namespace nvs {

struct Fnv1a {
    std::uint64_t h;
    // The offset basis is a parameter: the atmosphere table's cache keys were made with their
    // own, and changing it would invalidate every stored table.
    explicit Fnv1a(std::uint64_t basis = 0xcbf29ce484222325ull) : h(basis) {}
    void bytes(const void* p, std::size_t n) {
        const auto* c = static_cast<const unsigned char*>(p);
        for (std::size_t i = 0; i < n; ++i) {
            h ^= c[i];
            h *= 0x100000001b3ull;
        }
    }
};

}  // namespace nvs
