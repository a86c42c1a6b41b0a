#pragma once
// FakeSerialPort: an in-memory serial port for tests (test-only target nvs_drivers_serial_fake,
// built with NVS_BUILD_TESTS).

#include <cstddef>
#include <cstdint>
#include <deque>
#include <string>
#include <vector>

#include "drivers/serial/serial.h"

namespace nvs::drivers {

// In-memory port: tests queue byte chunks and failures; `reopenable` decides whether open()
// succeeds again after the device was lost.
class FakeSerialPort final : public SerialPort {
  public:
    int open(const std::string& device, int baud) override;
    void close() noexcept override { state_ = SerialState::Closed; }
    long read(std::uint8_t* buf, std::size_t size) noexcept override;
    SerialState state() const noexcept override { return state_; }
    const SerialCounters& counters() const noexcept override { return counters_; }

    void pushBytes(const std::string& bytes) { pushBytes(bytes.data(), bytes.size()); }
    void pushBytes(const void* data, std::size_t n);
    void pushError(int err) { chunks_.push_back({{}, err}); }
    bool reopenable = true;
    int opens = 0;

  private:
    struct Chunk {
        std::vector<std::uint8_t> bytes;
        int err;
    };
    std::deque<Chunk> chunks_;
    std::size_t offset_ = 0;
    SerialState state_ = SerialState::Closed;
    SerialCounters counters_;
};

}  // namespace nvs::drivers
