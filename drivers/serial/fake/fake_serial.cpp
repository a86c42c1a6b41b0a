#include "drivers/serial/fake/fake_serial.h"

#include <algorithm>
#include <cerrno>
#include <cstring>

namespace nvs::drivers {

int FakeSerialPort::open(const std::string& /*device*/, int /*baud*/) {
    if (state_ == SerialState::Lost && !reopenable) return -ENOENT;
    ++opens;
    state_ = SerialState::Open;
    return 0;
}

void FakeSerialPort::pushBytes(const void* data, std::size_t n) {
    const auto* p = static_cast<const std::uint8_t*>(data);
    chunks_.push_back({std::vector<std::uint8_t>(p, p + n), 0});
}

long FakeSerialPort::read(std::uint8_t* buf, std::size_t size) noexcept {
    if (state_ != SerialState::Open) return -EBADF;
    if (chunks_.empty()) return 0;
    Chunk& c = chunks_.front();
    if (c.err != 0) {
        const int e = c.err;
        chunks_.pop_front();
        ++counters_.errors;
        counters_.lastErrno = e;
        if (e == EIO || e == ENXIO || e == ENODEV) {
            ++counters_.lost;
            state_ = SerialState::Lost;
        }
        return -e;
    }
    const std::size_t n = std::min(size, c.bytes.size() - offset_);
    std::memcpy(buf, c.bytes.data() + offset_, n);
    offset_ += n;
    if (offset_ == c.bytes.size()) {
        chunks_.pop_front();
        offset_ = 0;
    }
    counters_.bytes += static_cast<std::int64_t>(n);
    return static_cast<long>(n);
}

}  // namespace nvs::drivers
