#pragma once
// FakeCanBus: an in-memory CAN bus for tests (test-only target nvs_drivers_can_fake, built
// with NVS_BUILD_TESTS).

#include <deque>
#include <string>
#include <vector>

#include "drivers/can/can.h"

namespace nvs::drivers {

// In-memory bus: tests push frames (or raw garbage lengths) that read() returns in order.
class FakeCanBus final : public CanBus {
  public:
    int open(const std::string& iface, bool fd, const std::vector<CanFilter>& filters) override;
    void close() noexcept override { state_ = CanBusState::Closed; }
    int read(CanFrame* frame, double* rxRealtime_s) noexcept override;
    // Pending frames: 1 at once. None: sleeps for the timeout (as poll(2) would) and says 0.
    int waitReadable(int timeout_ms) noexcept override;
    int write(const CanFrame& frame) noexcept override;
    CanBusState state() const noexcept override { return state_; }
    const CanBusCounters& counters() const noexcept override { return counters_; }

    void push(const CanFrame& frame, double rxRealtime_s) {
        queue_.push_back({frame, rxRealtime_s, 0});
    }
    // A read that fails with -err (e.g. ENETDOWN: the interface went away).
    void pushError(int err) { queue_.push_back({CanFrame{}, 0.0, err}); }
    std::vector<CanFrame> written;
    int openError = 0;  // open() fails with -openError while set (the interface is still down)
    int opens = 0;

  private:
    struct Item {
        CanFrame frame;
        double rx_s;
        int err;
    };
    std::deque<Item> queue_;
    std::vector<CanFilter> filters_;
    CanBusState state_ = CanBusState::Closed;
    CanBusCounters counters_;
};

}  // namespace nvs::drivers
