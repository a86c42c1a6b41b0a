#include "drivers/gpio/gpio.h"

#include <gpiod.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "sim/core/error.h"

namespace nvs::drivers {

namespace {
constexpr const char* kConsumer = "nvstim";

// CLOCK_REALTIME now [ns] (to recognise event stamps of kernels before 5.7).
std::int64_t realtimeNow_ns() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_REALTIME, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

// Sleeps until `deadline_ns` on CLOCK_MONOTONIC (absolute: never early, no drift when cut
// short). 0, or -EINTR when a signal interrupted it.
int sleepUntilMonotonic(std::int64_t deadline_ns) noexcept {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(deadline_ns / 1'000'000'000);
    ts.tv_nsec = static_cast<long>(deadline_ns % 1'000'000'000);
    const int rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    return rc == 0 ? 0 : -rc;
}
}  // namespace

std::int64_t gpioMonotonicNow_ns() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

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

// ---- spec ----------------------------------------------------------------------------------

bool parseGpioTarget(const std::string& target, std::string* chip, unsigned* line) {
    const auto colon = target.rfind(':');
    if (colon == std::string::npos || colon == 0 || colon + 1 == target.size()) return false;
    const std::string lineText = target.substr(colon + 1);
    char* end = nullptr;
    const unsigned long n = std::strtoul(lineText.c_str(), &end, 10);
    if (*end != '\0' || n > 1023 || lineText[0] == '-' || lineText[0] == '+') return false;
    *chip = target.substr(0, colon);
    *line = static_cast<unsigned>(n);
    return true;
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
}

GpioGateSink::~GpioGateSink() {
    close();
}

void GpioGateSink::exposureScheduled(const msg::ExposureWindow& w) noexcept {
    if (closed_.load(std::memory_order_relaxed)) return;
    // Width: the gate when the photocathode is gated within the exposure, else the exposure.
    const double width_s = w.gate_s > 0.0 && w.gate_s < w.exposure_s ? w.gate_s : w.exposure_s;
    // Handed over after its start (a frame made too late for its exposure; the trigger clock,
    // whose exposures start at the edge): this pulse rises late whatever the pulse thread does.
    if (w.startMonotonic_ns != 0 && w.startMonotonic_ns < gpioMonotonicNow_ns())
        queuedLate_.fetch_add(1, std::memory_order_relaxed);
    const std::uint32_t t = tail_.load(std::memory_order_relaxed);
    if (t - head_.load(std::memory_order_acquire) >= kQueue) {
        lost_.fetch_add(1, std::memory_order_relaxed);
        return;
    }
    queue_[t % kQueue] = Pulse{w.startMonotonic_ns, std::llround(width_s * 1e9)};
    tail_.store(t + 1, std::memory_order_release);
    wake_.fetch_add(1, std::memory_order_release);
    wake_.notify_one();
}

void GpioGateSink::runWorker() noexcept {
    // Announce the run before checking for close(): close() sets closed_ before reading
    // active_ (both sequentially consistent), so either it waits for this run or this run
    // sees it closed and leaves the line alone.
    active_.store(true);
    if (closed_.load()) {
        active_.store(false);
        active_.notify_all();
        return;
    }
    std::int64_t lastFall_ns = 0;
    for (;;) {
        const std::uint32_t seen = wake_.load(std::memory_order_acquire);
        const std::uint32_t h = head_.load(std::memory_order_relaxed);
        const std::uint32_t t = tail_.load(std::memory_order_acquire);
        if (h == t) {
            // Stop once every scheduled pulse is out (stopWorker() comes after the loop's end,
            // so nothing more is scheduled; the last ones end within a period or two).
            if (stop_.load(std::memory_order_acquire)) break;
            wake_.wait(seen, std::memory_order_acquire);
            continue;
        }
        const Pulse p = queue_[h % kQueue];
        head_.store(h + 1, std::memory_order_release);
        const std::int64_t now_ns = gpioMonotonicNow_ns();
        // Step 1: the start of the exposure on CLOCK_MONOTONIC (sim clock: now).
        std::int64_t start_ns = p.start_ns != 0 ? p.start_ns : now_ns;
        if (start_ns - now_ns > 2'000'000'000) {
            // More than two seconds ahead cannot come from the loop's timeline.
            errors_.fetch_add(1, std::memory_order_relaxed);
            continue;
        }
        if (start_ns < lastFall_ns) {
            // Exposure windows that overlap cannot both be marked on one line: this one rises
            // when the previous pulse ends.
            overlapped_.fetch_add(1, std::memory_order_relaxed);
            start_ns = lastFall_ns;
        }
        // Step 2: rise at the start (absolute sleep: never early).
        while (sleepUntilMonotonic(start_ns) == -EINTR) {
        }
        const std::int64_t rise_ns = gpioMonotonicNow_ns();
        if (const int rc = line_->setValue(1); rc != 0) noteError(rc);
        // Step 3: fall at the end of the window, start + width, on the absolute clock: a late
        // rise (scheduled after its start: trigger clock, a late render; or a late wake-up)
        // shortens the pulse but never shifts the windows after it. A window already over
        // still gives a pulse, as short as the line allows, so that pulses can be counted.
        const std::int64_t fall_ns = std::max(start_ns + p.width_ns, rise_ns);
        if (rise_ns - start_ns > kGateLate_ns) late_.fetch_add(1, std::memory_order_relaxed);
        if (rise_ns - start_ns > riseDelayMax_ns_.load(std::memory_order_relaxed))
            riseDelayMax_ns_.store(rise_ns - start_ns, std::memory_order_relaxed);
        while (sleepUntilMonotonic(fall_ns) == -EINTR) {
        }
        if (const int rc = line_->setValue(0); rc != 0) noteError(rc);
        lastFall_ns = fall_ns;
        pulses_.fetch_add(1, std::memory_order_relaxed);
    }
    active_.store(false);
    active_.notify_all();
}

void GpioGateSink::stopWorker() noexcept {
    stop_.store(true, std::memory_order_release);
    wake_.fetch_add(1, std::memory_order_release);
    wake_.notify_all();
}

void GpioGateSink::noteError(int rc) noexcept {
    lastErrno_.store(-rc, std::memory_order_relaxed);
    errors_.fetch_add(1, std::memory_order_release);
}

int GpioGateSink::write(const msg::OutputFrame& /*frame*/) noexcept {
    if (closed_.load(std::memory_order_relaxed)) return -EBADF;
    if (line_->state() == GpioState::Failed || errors_.load(std::memory_order_acquire) > 0) {
        const int err = lastErrno_.load(std::memory_order_relaxed);
        return -(err != 0 ? err : EIO);
    }
    return 0;
}

int GpioGateSink::close() noexcept {
    if (closed_.exchange(true)) return 0;
    // A pulse loop still running finishes the pulses it has, then returns.
    stopWorker();
    while (active_.load())
        active_.wait(true);
    line_->setValue(0);
    line_->release();
    return 0;
}

std::string GpioGateSink::status() const {
    char buf[320];
    // The line's own counters belong to the pulse thread while it runs: report its atomics.
    const std::int64_t errors = errors_.load(std::memory_order_acquire);
    const int lastErrno = lastErrno_.load(std::memory_order_relaxed);
    std::snprintf(
        buf, sizeof buf,
        "%s: pulses %lld, late %lld (rise after the exposure start: max %.3f ms; handed over "
        "after it %lld), overlapped %lld, lost %lld, errors %lld%s%s",
        name_.c_str(), static_cast<long long>(pulses_.load()), static_cast<long long>(late_.load()),
        static_cast<double>(riseDelayMax_ns_.load()) * 1e-6,
        static_cast<long long>(queuedLate_.load()), static_cast<long long>(overlapped_.load()),
        static_cast<long long>(lost_.load()), static_cast<long long>(errors),
        lastErrno != 0 ? ", last error: " : "", lastErrno != 0 ? std::strerror(lastErrno) : "");
    return buf;
}

// ---- trigger input ---------------------------------------------------------------------------

GpioTrigger::GpioTrigger(std::unique_ptr<GpioLine> line, const std::string& chip, unsigned offset)
    : line_(std::move(line)), name_("gpio:" + chip + ":" + std::to_string(offset)) {
    const int rc = line_->requestRisingEdges(chip, offset);
    if (rc != 0) {
        throw SetupError("trigger " + name_ +
                         ": cannot request the line for rising edges: " + std::strerror(-rc) +
                         " (gpiodetect / gpioinfo list the chips and lines; see docs/hil.md)");
    }
}

int GpioTrigger::waitEdge(std::int64_t timeout_ns, std::int64_t* edgeMonotonic_ns) noexcept {
    std::int64_t t_ns = 0;
    const int rc = line_->waitEdge(timeout_ns, &t_ns);
    if (rc != 1) return rc;
    // Kernels before 5.7 stamp v1 line events with CLOCK_REALTIME: a stamp nearer to the
    // realtime clock than to the monotonic one is moved by their present difference.
    const std::int64_t mono_ns = gpioMonotonicNow_ns();
    const std::int64_t real_ns = realtimeNow_ns();
    if (std::llabs(t_ns - real_ns) < std::llabs(t_ns - mono_ns)) {
        t_ns += mono_ns - real_ns;
        ++realtimeStamps_;
    }
    *edgeMonotonic_ns = t_ns;
    return 1;
}

std::string GpioTrigger::status() const {
    char buf[256];
    const GpioCounters& c = line_->counters();
    std::snprintf(buf, sizeof buf, "%s: edges %lld, errors %lld%s%s%s", name_.c_str(),
                  static_cast<long long>(c.edges), static_cast<long long>(c.errors),
                  realtimeStamps_ > 0 ? ", CLOCK_REALTIME stamps converted" : "",
                  c.lastErrno != 0 ? ", last error: " : "",
                  c.lastErrno != 0 ? std::strerror(c.lastErrno) : "");
    return buf;
}

}  // namespace nvs::drivers
