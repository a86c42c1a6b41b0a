#include "drivers/can/fake/fake_can.h"

#include <cerrno>
#include <chrono>
#include <thread>

namespace nvs::drivers {

int FakeCanBus::open(const std::string& /*iface*/, bool /*fd*/,
                     const std::vector<CanFilter>& filters) {
    ++opens;
    if (openError != 0) {
        state_ = CanBusState::Failed;
        return -openError;
    }
    filters_ = filters;
    state_ = CanBusState::Open;
    return 0;
}

int FakeCanBus::read(CanFrame* frame, double* rxRealtime_s) noexcept {
    if (state_ != CanBusState::Open) return -EBADF;
    while (!queue_.empty()) {
        const Item item = queue_.front();
        queue_.pop_front();
        if (item.err != 0) {
            ++counters_.errors;
            counters_.lastErrno = item.err;
            if (item.err == ENETDOWN || item.err == ENODEV) state_ = CanBusState::Failed;
            return -item.err;
        }
        // The kernel's filter rule: pass when (id & mask) == (filter id & mask) for any filter.
        bool pass = filters_.empty();
        for (const CanFilter& f : filters_) {
            if ((item.frame.id & f.mask) == (f.id & f.mask)) pass = true;
        }
        if (!pass) continue;
        *frame = item.frame;
        *rxRealtime_s = item.rx_s;
        ++counters_.frames;
        return 1;
    }
    return 0;
}

int FakeCanBus::waitReadable(int timeout_ms) noexcept {
    if (state_ != CanBusState::Open) return -EBADF;
    if (!queue_.empty()) return 1;
    std::this_thread::sleep_for(std::chrono::milliseconds(timeout_ms));
    return 0;
}

int FakeCanBus::write(const CanFrame& frame) noexcept {
    if (state_ != CanBusState::Open) return -EBADF;
    written.push_back(frame);
    return 0;
}

}  // namespace nvs::drivers
