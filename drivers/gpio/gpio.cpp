#include "drivers/gpio/gpio.h"

#include <gpiod.h>
#include <time.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "rt/clock/clock.h"
#include "rt/clock/threads.h"
#include "sim/core/error.h"

namespace nvs::drivers {

namespace {
constexpr const char* kConsumer = "nvstim";
}  // namespace

// ---- libgpiod v1 ---------------------------------------------------------------------------

int GpiodLine::open(const std::string& chip, unsigned line) {
    release();
    chip_ = gpiod_chip_open_by_name(chip.c_str());
    if (chip_ == nullptr) return -(errno != 0 ? errno : ENODEV);
    line_ = gpiod_chip_get_line(chip_, line);
    if (line_ == nullptr) {
        const int err = errno != 0 ? errno : EINVAL;
        gpiod_chip_close(chip_);
        chip_ = nullptr;
        return -err;
    }
    return 0;
}

int GpiodLine::requestOutput(const std::string& chip, unsigned line, bool activeLow) {
    int rc = open(chip, line);
    if (rc != 0) return rc;
    const int flags = activeLow ? GPIOD_LINE_REQUEST_FLAG_ACTIVE_LOW : 0;
    gpiod_line_request_config cfg{kConsumer, GPIOD_LINE_REQUEST_DIRECTION_OUTPUT, flags};
    if (gpiod_line_request(line_, &cfg, 0) < 0) {
        rc = -errno;
        release();
        return rc;
    }
    state_ = GpioState::Output;
    return 0;
}

int GpiodLine::requestRisingEdges(const std::string& chip, unsigned line) {
    int rc = open(chip, line);
    if (rc != 0) return rc;
    if (gpiod_line_request_rising_edge_events(line_, kConsumer) < 0) {
        rc = -errno;
        release();
        return rc;
    }
    state_ = GpioState::Input;
    return 0;
}

int GpiodLine::setValue(int value) noexcept {
    if (state_ != GpioState::Output) return -EBADF;
    if (gpiod_line_set_value(line_, value) < 0) {
        ++counters_.errors;
        counters_.lastErrno = errno;
        return -errno;
    }
    ++counters_.sets;
    return 0;
}

int GpiodLine::waitEdge(std::int64_t timeout_ns, std::int64_t* edge_ns) noexcept {
    if (state_ != GpioState::Input) return -EBADF;
    timespec ts{static_cast<time_t>(timeout_ns / 1000000000),
                static_cast<long>(timeout_ns % 1000000000)};
    const int rc = gpiod_line_event_wait(line_, &ts);
    if (rc < 0) {
        ++counters_.errors;
        counters_.lastErrno = errno;
        return -errno;
    }
    if (rc == 0) return 0;
    gpiod_line_event ev{};
    if (gpiod_line_event_read(line_, &ev) < 0) {
        ++counters_.errors;
        counters_.lastErrno = errno;
        return -errno;
    }
    ++counters_.edges;
    *edge_ns = static_cast<std::int64_t>(ev.ts.tv_sec) * 1000000000 + ev.ts.tv_nsec;
    return 1;
}

void GpiodLine::release() noexcept {
    if (line_ != nullptr && state_ != GpioState::Closed) gpiod_line_release(line_);
    line_ = nullptr;
    if (chip_ != nullptr) gpiod_chip_close(chip_);
    chip_ = nullptr;
    state_ = GpioState::Closed;
}

// ---- fake ------------------------------------------------------------------------------------

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
    if (failErr_ != 0) {
        ++counters_.errors;
        counters_.lastErrno = failErr_;
        return -failErr_;
    }
    if (state_ != GpioState::Output) return -EBADF;
    if (changes_.size() < changes_.capacity()) changes_.push_back({value, rt::monotonicNow_ns()});
    ++counters_.sets;
    return 0;
}

int FakeGpioLine::waitEdge(std::int64_t /*timeout_ns*/, std::int64_t* edge_ns) noexcept {
    if (failErr_ != 0) return -failErr_;
    if (state_ != GpioState::Input) return -EBADF;
    if (edges_.empty()) return 0;  // a timeout: the fake does not sleep
    *edge_ns = edges_.front();
    edges_.pop_front();
    ++counters_.edges;
    return 1;
}

// ---- gate pulse sink -------------------------------------------------------------------------

GpioGateSink::GpioGateSink(std::unique_ptr<GpioLine> line, const std::string& chip, unsigned offset,
                           bool activeLow)
    : line_(std::move(line)), name_("gpio:" + chip + ":" + std::to_string(offset)) {
    const int rc = line_->requestOutput(chip, offset, activeLow);
    if (rc != 0) {
        throw SetupError(name_ + ": cannot request the line as an output: " + std::strerror(-rc) +
                         " (gpiodetect / gpioinfo list the chips and lines; see docs/hil.md)");
    }
    line_->setValue(0);
    thread_ = std::thread([this] { pulseThread(); });
}

GpioGateSink::~GpioGateSink() {
    close();
}

void GpioGateSink::pulseThread() {
    std::string msg;
    rt::applyThreadSpec(rt::kThreadGpio, false, msg);
    std::uint32_t seen = 0;
    for (;;) {
        seq_.wait(seen, std::memory_order_acquire);
        if (stop_.load(std::memory_order_acquire)) break;
        seen = seq_.load(std::memory_order_acquire);
        // Step 1: raise at once (the frame is being emitted now).
        const std::int64_t rise_ns = rt::monotonicNow_ns();
        if (line_->setValue(1) != 0) errors_.fetch_add(1, std::memory_order_relaxed);
        // Step 2: lower gate_s after the rise, on the absolute CLOCK_MONOTONIC instant.
        const std::int64_t end_ns = rise_ns + width_ns_.load(std::memory_order_acquire);
        while (rt::WallClock::sleepUntil(end_ns) == -EINTR) {
        }
        if (line_->setValue(0) != 0) errors_.fetch_add(1, std::memory_order_relaxed);
        pulses_.fetch_add(1, std::memory_order_relaxed);
        // A request that came while the line was high starts late: count it.
        if (seq_.load(std::memory_order_acquire) != seen) {
            overlapped_.fetch_add(1, std::memory_order_relaxed);
        }
    }
}

int GpioGateSink::write(const rt::OutputFrame& frame) noexcept {
    if (closed_) return -EBADF;
    const double gate_s = frame.meta->platform.gate_s;
    const double width_s =
        gate_s > 0.0 && gate_s < frame.meta->exposure_s ? gate_s : frame.meta->exposure_s;
    width_ns_.store(static_cast<std::int64_t>(width_s * 1e9), std::memory_order_release);
    seq_.fetch_add(1, std::memory_order_release);
    seq_.notify_one();
    if (line_->state() == GpioState::Failed || errors_.load(std::memory_order_relaxed) > 0) {
        return -(line_->counters().lastErrno != 0 ? line_->counters().lastErrno : EIO);
    }
    return 0;
}

int GpioGateSink::close() noexcept {
    if (closed_) return 0;
    closed_ = true;
    stop_.store(true, std::memory_order_release);
    seq_.fetch_add(1, std::memory_order_release);
    seq_.notify_one();
    if (thread_.joinable()) thread_.join();
    line_->setValue(0);
    line_->release();
    return 0;
}

std::string GpioGateSink::status() const {
    char buf[256];
    const GpioCounters& c = line_->counters();
    std::snprintf(buf, sizeof buf, "%s: pulses %lld, overlapped %lld, errors %lld%s%s",
                  name_.c_str(), static_cast<long long>(pulses_.load()),
                  static_cast<long long>(overlapped_.load()),
                  static_cast<long long>(errors_.load()), c.lastErrno != 0 ? ", last error: " : "",
                  c.lastErrno != 0 ? std::strerror(c.lastErrno) : "");
    return buf;
}

}  // namespace nvs::drivers
