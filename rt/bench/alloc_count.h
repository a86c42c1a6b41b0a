#pragma once
// Counting the global operator new: every form (plain, array, aligned, nothrow) adds one to a
// process-wide counter when the program links rt/bench/count_new.cpp (nvstim and the
// allocation tests do). `nvstim bench` and tests/rt/bench use it to show that the frame loop
// allocates nothing per field in steady state (docs/style.md §3). Memory that Embree, TBB or FFTW
// take with malloc directly is not counted.

#include <atomic>
#include <cstdint>

namespace nvs::rt::bench {

namespace detail {
extern std::atomic<std::uint64_t> gAllocations;
extern std::atomic<bool> gCounting;
}  // namespace detail

// Calls of the global operator new since the program started.
inline std::uint64_t allocationCount() noexcept {
    return detail::gAllocations.load(std::memory_order_relaxed);
}
// True when the program links the counting operator new (else allocationCount() stays 0).
inline bool allocationCounting() noexcept {
    return detail::gCounting.load(std::memory_order_relaxed);
}

}  // namespace nvs::rt::bench
