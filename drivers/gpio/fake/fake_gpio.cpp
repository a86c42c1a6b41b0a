#include "drivers/gpio/fake/fake_gpio.h"

#include <algorithm>
#include <cerrno>
#include <chrono>

namespace nvs::drivers {

int FakeGpioLine::requestOutput(const std::string& chipName, unsigned line, bool low) {
    if (chipName != chip) return -ENOENT;
    if (line >= lines) return -EINVAL;
    activeLow = low;
    state_ = GpioState::Output;
    return 0;
}

int FakeGpioLine::requestRisingEdges(const std::string& chipName, unsigned line) {
    if (chipName != chip) return -ENOENT;
    if (line >= lines) return -EINVAL;
    state_ = GpioState::Input;
    return 0;
}

int FakeGpioLine::setValue(int value) noexcept {
    const int err = failErr_.load();
    if (err != 0) {
        ++counters_.errors;
        counters_.lastErrno = err;
        return -err;
    }
    if (state_ != GpioState::Output) return -EBADF;
    if (changes_.size() < changes_.capacity()) changes_.push_back({value, gpioMonotonicNow_ns()});
    ++counters_.sets;
    return 0;
}

void FakeGpioLine::pushEdge(std::int64_t t_ns) {
    {
        const std::lock_guard<std::mutex> lock(edgeMutex_);
        edges_.push_back(t_ns);
    }
    edgeCv_.notify_all();
}

int FakeGpioLine::waitEdge(std::int64_t timeout_ns, std::int64_t* edge_ns) noexcept {
    if (failErr_.load() != 0) return -failErr_.load();
    if (state_ != GpioState::Input) return -EBADF;
    const std::int64_t until_ns = gpioMonotonicNow_ns() + timeout_ns;
    std::unique_lock<std::mutex> lock(edgeMutex_);
    for (;;) {
        const std::int64_t now_ns = gpioMonotonicNow_ns();
        // An edge is delivered once its time has come, as the kernel delivers a real one.
        if (!edges_.empty() && edges_.front() <= now_ns) {
            *edge_ns = edges_.front();
            edges_.pop_front();
            ++counters_.edges;
            return 1;
        }
        if (now_ns >= until_ns) return 0;
        const std::int64_t wake_ns = edges_.empty() ? until_ns : std::min(until_ns, edges_.front());
        // steady_clock is CLOCK_MONOTONIC (libstdc++ on Linux).
        edgeCv_.wait_until(
            lock, std::chrono::steady_clock::time_point(std::chrono::nanoseconds(wake_ns)));
    }
}

}  // namespace nvs::drivers
