#include "rt/clock/clock.h"

#include <pthread.h>
#include <sched.h>
#include <sys/mman.h>
#include <time.h>

#include <cerrno>
#include <cmath>
#include <cstring>

#include "sim/core/error.h"

namespace nvs::rt {

namespace {
// 128-bit products for k·den·1e9 (GCC/Clang extension).
__extension__ typedef __int128 Int128;
}  // namespace

std::int64_t monotonicNow_ns() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::int64_t realtimeNow_ns() noexcept {
    timespec ts{};
    clock_gettime(CLOCK_REALTIME, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

std::int64_t WallClock::deadline_ns(std::int64_t k) const noexcept {
    // 128-bit product: k·den·1e9 overflows 64 bits after ~10⁷ NTSC frames (two days).
    const Int128 num = static_cast<Int128>(k) * rate_.den * 1'000'000'000;
    return start_ns_ + static_cast<std::int64_t>(num / rate_.num);
}

std::int64_t WallClock::tickAt(std::int64_t t_ns) const noexcept {
    const std::int64_t dt = t_ns - start_ns_;
    if (dt < 0) return -1;
    // Inverse of deadline_ns: the largest k with floor(k·den·1e9/num) <= dt.
    const Int128 k =
        static_cast<Int128>(dt) * rate_.num / (static_cast<Int128>(rate_.den) * 1'000'000'000);
    std::int64_t kk = static_cast<std::int64_t>(k);
    while (deadline_ns(kk + 1) <= t_ns)
        ++kk;
    while (kk > 0 && deadline_ns(kk) > t_ns)
        --kk;
    return kk;
}

int WallClock::sleepUntil(std::int64_t deadline_ns) noexcept {
    timespec ts{};
    ts.tv_sec = static_cast<time_t>(deadline_ns / 1'000'000'000);
    ts.tv_nsec = static_cast<long>(deadline_ns % 1'000'000'000);
    const int rc = clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr);
    return rc == 0 ? 0 : -rc;
}

int makeThreadRealtime(int priority, int cpu, std::string& message) {
    if (cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET(static_cast<std::size_t>(cpu), &set);
        const int rc = pthread_setaffinity_np(pthread_self(), sizeof(set), &set);
        if (rc != 0) {
            message = "cannot pin thread to CPU " + std::to_string(cpu) + ": " + std::strerror(rc) +
                      "; running unpinned";
        }
    }
    sched_param sp{};
    sp.sched_priority = priority;
    const int rc = pthread_setschedparam(pthread_self(), SCHED_FIFO, &sp);
    if (rc != 0) {
        message = std::string("SCHED_FIFO priority ") + std::to_string(priority) +
                  " not permitted (" + std::strerror(rc) +
                  "): run as root, grant CAP_SYS_NICE (setcap cap_sys_nice+ep nvstim) or set "
                  "an rtprio limit in /etc/security/limits.conf; continuing with normal "
                  "scheduling";
        return -rc;
    }
    return 0;
}

int lockMemory(std::string& message) {
    if (mlockall(MCL_CURRENT | MCL_FUTURE) != 0) {
        const int e = errno;
        message = std::string("mlockall not permitted (") + std::strerror(e) +
                  "): raise the memlock limit (ulimit -l) or grant CAP_IPC_LOCK; pages may fault";
        return -e;
    }
    return 0;
}

}  // namespace nvs::rt
