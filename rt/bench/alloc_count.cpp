#include "rt/bench/alloc_count.h"

namespace nvs::rt::bench::detail {

// Constant-initialised (before any dynamic initialiser can allocate).
constinit std::atomic<std::uint64_t> gAllocations{0};
constinit std::atomic<bool> gCounting{false};

}  // namespace nvs::rt::bench::detail
