#pragma once
// FakeGpioLine: an in-memory GpioLine for tests (test-only target nvs_drivers_gpio_fake, built
// with NVS_BUILD_TESTS). It records every value set with its CLOCK_MONOTONIC time; edges are
// pushed (from any thread) with their time and delivered when that time has come: waitEdge
// sleeps until the first queued edge is due, up to its timeout.

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <vector>

#include "drivers/gpio/gpio.h"

namespace nvs::drivers {

class FakeGpioLine final : public GpioLine {
  public:
    struct Change {
        int value;
        std::int64_t t_ns;  // CLOCK_MONOTONIC
    };
    explicit FakeGpioLine(std::size_t capacity = 4096) { changes_.reserve(capacity); }
    int requestOutput(const std::string& chip, unsigned line, bool activeLow) override;
    int requestRisingEdges(const std::string& chip, unsigned line) override;
    int setValue(int value) noexcept override;
    int waitEdge(std::int64_t timeout_ns, std::int64_t* edge_ns) noexcept override;
    void release() noexcept override { state_ = GpioState::Closed; }
    GpioState state() const noexcept override { return state_; }
    const GpioCounters& counters() const noexcept override { return counters_; }

    std::string chip = "gpiochip0";  // the only chip that exists
    unsigned lines = 32;             // lines it has
    bool activeLow = false;
    // Queues a rising edge stamped t_ns (CLOCK_MONOTONIC), delivered once t_ns has come.
    void pushEdge(std::int64_t t_ns);
    void fail(int err) { failErr_ = err; }  // from now on every call fails with -err
    // Written by setValue (up to the capacity given; read after the writer has stopped).
    const std::vector<Change>& changes() const { return changes_; }

  private:
    GpioState state_ = GpioState::Closed;
    GpioCounters counters_;
    std::vector<Change> changes_;
    std::mutex edgeMutex_;
    std::condition_variable edgeCv_;
    std::deque<std::int64_t> edges_;
    std::atomic<int> failErr_{0};
};

}  // namespace nvs::drivers
