// The HIL test's GPIO helper, run inside the virtual machine (tests/hil/init.sh) against a
// gpio-sim chip: it makes trigger edges through the simulator's sysfs `pull` attribute, samples
// a line's `value` attribute at known times, and stamps lines read from a pipe, each with
// CLOCK_MONOTONIC (the clock of the kernel's line-event stamps and of nvstim's run clock). A
// shell in the VM has no such clock (busybox has none finer than /proc/uptime's 10 ms).
//
//   hil_gpio edges PULL N PERIOD_US JITTER_US SEED [STALL_AFTER STALL_US]
//       N rising edges: "pull-up" written to PULL at t0 + i·PERIOD + jitter_i (jitter uniform
//       in ±JITTER_US from a seeded generator), "pull-down" half a period later; after
//       STALL_AFTER edges a silence of STALL_US more. One line per rising edge on stdout:
//       "i scheduled_ns before_ns after_ns" (CLOCK_MONOTONIC just before and just after the
//       write: the kernel stamps the edge in between, or just after when irq_work defers it).
//   hil_gpio sample VALUE PERIOD_US STOPFILE [MAX_S]
//       reads VALUE (a sysfs `value` attribute: "0" or "1") every PERIOD_US on an absolute
//       schedule until STOPFILE exists (or MAX_S, default 60); one line per sample:
//       "before_ns after_ns value", the line's level at an instant between the two. Slots
//       already past when the sampler gets the CPU back are skipped, not read in a burst (a
//       burst at its real-time priority would hold up the threads whose pulse it samples).
//   hil_gpio stamp
//       copies stdin to stdout, each line prefixed with "arrival_ns " (CLOCK_MONOTONIC when
//       it was read).
//   hil_gpio now
//       prints CLOCK_MONOTONIC [ns].
// Exit 0, or 2 with a message on stderr.
#include <fcntl.h>
#include <time.h>
#include <unistd.h>

#include <cerrno>
#include <cinttypes>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

namespace {

std::int64_t now_ns() {
    timespec ts{};
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
}

void sleepUntil(std::int64_t t_ns) {
    timespec ts{static_cast<time_t>(t_ns / 1'000'000'000), static_cast<long>(t_ns % 1'000'000'000)};
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &ts, nullptr) == EINTR) {
    }
}

int die(const char* what) {
    std::fprintf(stderr, "hil_gpio: %s: %s\n", what, std::strerror(errno));
    return 2;
}

bool writeAttr(int fd, const char* text) {
    const std::size_t n = std::strlen(text);
    return pwrite(fd, text, n, 0) == static_cast<ssize_t>(n);
}

// splitmix64: a small seeded generator for the jitter (the same sequence for the same seed).
std::uint64_t nextRandom(std::uint64_t& s) {
    std::uint64_t z = (s += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

int edges(int argc, char** argv) {
    if (argc < 7) return die("usage: edges PULL N PERIOD_US JITTER_US SEED [STALL_AFTER STALL_US]");
    const int fd = open(argv[2], O_WRONLY);
    if (fd < 0) return die(argv[2]);
    const long n = std::atol(argv[3]);
    const std::int64_t period_ns = std::atoll(argv[4]) * 1000;
    const std::int64_t jitter_ns = std::atoll(argv[5]) * 1000;
    std::uint64_t seed = std::strtoull(argv[6], nullptr, 10);
    const long stallAfter = argc > 8 ? std::atol(argv[7]) : -1;
    const std::int64_t stall_ns = argc > 8 ? std::atoll(argv[8]) * 1000 : 0;
    if (!writeAttr(fd, "pull-down")) return die("pull-down");
    struct Edge {
        std::int64_t sched, before, after;
    };
    std::vector<Edge> out(static_cast<std::size_t>(n));
    const std::int64_t t0 = now_ns() + 100'000'000;
    for (long i = 0; i < n; ++i) {
        const double u = static_cast<double>(nextRandom(seed) >> 11) * 0x1.0p-53;  // [0, 1)
        std::int64_t t =
            t0 + i * period_ns +
            static_cast<std::int64_t>((2.0 * u - 1.0) * static_cast<double>(jitter_ns));
        if (stallAfter >= 0 && i >= stallAfter) t += stall_ns;
        sleepUntil(t);
        Edge& e = out[static_cast<std::size_t>(i)];
        e.sched = t;
        e.before = now_ns();
        if (!writeAttr(fd, "pull-up")) return die("pull-up");
        e.after = now_ns();
        sleepUntil(t + period_ns / 2);
        if (!writeAttr(fd, "pull-down")) return die("pull-down");
    }
    for (long i = 0; i < n; ++i) {
        const Edge& e = out[static_cast<std::size_t>(i)];
        std::printf("%ld %" PRId64 " %" PRId64 " %" PRId64 "\n", i, e.sched, e.before, e.after);
    }
    close(fd);
    return 0;
}

int sample(int argc, char** argv) {
    if (argc < 5) return die("usage: sample VALUE PERIOD_US STOPFILE [MAX_S]");
    const int fd = open(argv[2], O_RDONLY);
    if (fd < 0) return die(argv[2]);
    const std::int64_t period_ns = std::atoll(argv[3]) * 1000;
    const std::string stopFile = argv[4];
    const double max_s = argc > 5 ? std::atof(argv[5]) : 60.0;
    struct Sample {
        std::int64_t before, after;
        char value;
    };
    std::vector<Sample> out;
    out.reserve(static_cast<std::size_t>(max_s * 1e9 / static_cast<double>(period_ns)) + 16);
    const std::int64_t t0 = now_ns();
    const std::int64_t end = t0 + static_cast<std::int64_t>(max_s * 1e9);
    std::int64_t nextCheck = t0;
    for (std::int64_t j = 0;; ++j) {
        const std::int64_t late_ns = now_ns() - (t0 + j * period_ns);
        if (late_ns > period_ns) j += late_ns / period_ns;  // skip the slots already past
        const std::int64_t t = t0 + j * period_ns;
        if (t > end) break;
        // Every 50 ms: stop once asked to.
        if (t >= nextCheck) {
            if (access(stopFile.c_str(), F_OK) == 0) break;
            nextCheck = t + 50'000'000;
        }
        sleepUntil(t);
        char buf[8] = {};
        Sample s{now_ns(), 0, '?'};
        if (pread(fd, buf, sizeof buf, 0) < 1) return die("read value");
        s.after = now_ns();
        s.value = buf[0];
        if (out.size() < out.capacity()) out.push_back(s);
    }
    for (const Sample& s : out)
        std::printf("%" PRId64 " %" PRId64 " %c\n", s.before, s.after, s.value);
    close(fd);
    return 0;
}

int stamp() {
    char line[8192];
    while (std::fgets(line, sizeof line, stdin) != nullptr) {
        std::printf("%" PRId64 " %s", now_ns(), line);
        std::fflush(stdout);
    }
    return 0;
}

}  // namespace

int main(int argc, char** argv) {
    const std::string cmd = argc > 1 ? argv[1] : "";
    if (cmd == "edges") return edges(argc, argv);
    if (cmd == "sample") return sample(argc, argv);
    if (cmd == "stamp") return stamp();
    if (cmd == "now") {
        std::printf("%" PRId64 "\n", now_ns());
        return 0;
    }
    std::fprintf(stderr, "usage: hil_gpio edges|sample|stamp|now ...\n");
    return 2;
}
