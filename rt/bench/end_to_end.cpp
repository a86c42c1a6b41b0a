#include "rt/bench/end_to_end.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "rt/bench/alloc_count.h"
#include "rt/bench/timed_items.h"
#include "rt/run/run.h"

namespace nvs::rt::bench {
namespace {

// What the child sends back through its pipe: this, `lines` doubles (when each frame's
// metadata line arrived), then an error text when rc ≠ 0.
struct ChildReport {
    int rc = -1;
    std::uint64_t windowAllocations = 0;  // operator new calls between the window's two lines
    double windowCpu_s = 0.0;             // CPU time of every thread between them
    int lines = 0;
};

// CPU time (user + system) of every thread of this process so far (getrusage(2), RUSAGE_SELF).
double processCpu_s() {
    rusage ru{};
    getrusage(RUSAGE_SELF, &ru);
    const auto s = [](const timeval& t) {
        return static_cast<double>(t.tv_sec) + static_cast<double>(t.tv_usec) * 1e-6;
    };
    return s(ru.ru_utime) + s(ru.ru_stime);
}

// What the watcher notes at the two ends of the steady window.
struct WindowMarks {
    std::uint64_t alloc0 = 0, alloc1 = 0;
    double cpu0_s = 0.0, cpu1_s = 0.0;
};

struct ChildRun {
    bool ok = false;
    std::string error;
    std::uint64_t windowAllocations = 0;
    double windowCpu_s = 0.0;
    double maxRss_MiB = 0.0;
    std::vector<double> emitted_s;  // when each frame's metadata line arrived (steady clock)
};

double steadyNow_s() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

// The child's watcher thread: reads the metadata lines until end of file, noting when each
// arrives and the allocation count at lines `from` and `to` (it allocates nothing itself).
void watchLines(int fd, int from, int to, std::vector<double>& times, WindowMarks& marks) {
    char buf[65536];
    for (ssize_t n; (n = read(fd, buf, sizeof buf)) != 0;) {
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) break;
        const double now = steadyNow_s();
        for (ssize_t i = 0; i < n; ++i) {
            if (buf[i] != '\n' || times.size() == times.capacity()) continue;
            times.push_back(now);
            const auto line = static_cast<int>(times.size());
            if (line == from) {
                marks.alloc0 = allocationCount();
                marks.cpu0_s = processCpu_s();
            }
            if (line == to) {
                marks.alloc1 = allocationCount();
                marks.cpu1_s = processCpu_s();
            }
        }
    }
}

// The run itself, in the child: the metadata output (stdout) goes to a pipe its watcher thread
// reads. The allocation window runs from frame warmFrames to the frame before the last two
// (by then the render thread has rendered its last frame; after the last the loop shuts down).
[[noreturn]] void childMain(const EndToEndRequest& req, const std::filesystem::path& stats,
                            int fd) {
    ChildReport rep;
    std::string error;
    std::vector<double> times;
    try {
        int lines[2];
        if (pipe(lines) != 0 || dup2(lines[1], STDOUT_FILENO) < 0) throw std::runtime_error("pipe");
        close(lines[1]);
        times.reserve(static_cast<std::size_t>(req.frames) + 1);
        WindowMarks marks;
        std::thread watcher(watchLines, lines[0], req.warmFrames, req.frames - 2, std::ref(times),
                            std::ref(marks));
        RunRequest run;
        run.scenario = req.scenario.string();
        run.outputs = {"y4m:/dev/null", "meta:-"};
        run.clock = ClockKind::Sim;
        run.frames = req.frames;
        run.statsPath = stats.string();
        run.dirs = req.dirs;
        run.primaryVisibility = req.primaryVisibility;
        run.renderThreads = req.renderThreads;
        run.cameraThreads = req.cameraThreads;
        std::FILE* quiet = std::fopen("/dev/null", "w");
        rep.rc = runScenario(run, quiet != nullptr ? quiet : stderr);
        close(STDOUT_FILENO);  // the watcher's end of file
        watcher.join();
        rep.windowAllocations = marks.alloc1 - marks.alloc0;
        rep.windowCpu_s = marks.cpu1_s - marks.cpu0_s;
        if (rep.rc != 0) error = "nvstim run exited with status " + std::to_string(rep.rc);
    } catch (const std::exception& e) {
        rep.rc = -1;
        error = e.what();
    }
    rep.lines = static_cast<int>(times.size());
    (void)!write(fd, &rep, sizeof rep);
    (void)!write(fd, times.data(), times.size() * sizeof(double));
    (void)!write(fd, error.data(), error.size());
    close(fd);
    _exit(0);
}

ChildRun runChild(const EndToEndRequest& req, const std::filesystem::path& stats) {
    ChildRun out;
    int fds[2];
    if (pipe(fds) != 0) {
        out.error = std::string("pipe: ") + std::strerror(errno);
        return out;
    }
    std::fflush(nullptr);
    const pid_t pid = fork();
    if (pid < 0) {
        out.error = std::string("fork: ") + std::strerror(errno);
        return out;
    }
    if (pid == 0) {
        close(fds[0]);
        childMain(req, stats, fds[1]);
    }
    close(fds[1]);
    std::string bytes;
    char buf[4096];
    for (ssize_t n; (n = read(fds[0], buf, sizeof buf)) != 0;) {
        if (n < 0 && errno == EINTR) continue;
        if (n < 0) break;
        bytes.append(buf, static_cast<std::size_t>(n));
    }
    close(fds[0]);
    int status = 0;
    rusage ru{};
    while (wait4(pid, &status, 0, &ru) < 0 && errno == EINTR) {
    }
    ChildReport rep;
    if (bytes.size() < sizeof rep) {
        out.error =
            "the run's process ended without a report (status " + std::to_string(status) + ")";
        return out;
    }
    std::memcpy(&rep, bytes.data(), sizeof rep);
    const std::size_t timesBytes = static_cast<std::size_t>(rep.lines) * sizeof(double);
    if (rep.lines < 0 || bytes.size() < sizeof rep + timesBytes) {
        out.error = "the run's process sent a short report";
        return out;
    }
    out.emitted_s.resize(static_cast<std::size_t>(rep.lines));
    std::memcpy(out.emitted_s.data(), bytes.data() + sizeof rep, timesBytes);
    out.ok = rep.rc == 0;
    out.error = bytes.substr(sizeof rep + timesBytes);
    out.windowAllocations = rep.windowAllocations;
    out.windowCpu_s = rep.windowCpu_s;
    out.maxRss_MiB = static_cast<double>(ru.ru_maxrss) / 1024.0;  // ru_maxrss: KiB (getrusage(2))
    return out;
}

// The number after "key": inside the object "object": (the whole text when object is empty)
// of the run's statistics (rt/run statsJson, a fixed layout).
double number(const std::string& json, const std::string& object, const std::string& key) {
    std::size_t from = 0;
    if (!object.empty()) {
        from = json.find("\"" + object + "\":{");
        if (from == std::string::npos) return 0.0;
    }
    const std::size_t at = json.find("\"" + key + "\":", from);
    if (at == std::string::npos) return 0.0;
    return std::strtod(json.c_str() + at + key.size() + 3, nullptr);
}

}  // namespace

EndToEndResult runEndToEnd(const EndToEndRequest& req) {
    EndToEndResult r;
    const std::filesystem::path stats =
        std::filesystem::temp_directory_path() /
        ("nvstim-bench-" + std::to_string(getpid()) + "-" + req.name + ".json");
    std::fprintf(stderr, "nvstim bench: %s: %d frames under the sim clock ...\n", req.name.c_str(),
                 req.frames);
    const ChildRun full = runChild(req, stats);
    if (!full.ok) {
        r.error = full.error;
        std::filesystem::remove(stats);
        return r;
    }
    std::ifstream in(stats);
    std::stringstream ss;
    ss << in.rdbuf();
    const std::string json = ss.str();
    std::filesystem::remove(stats);
    r.fieldsPerFrame = json.find("\"scan\":\"interlaced\"") != std::string::npos ? 2 : 1;
    r.frames = static_cast<std::int64_t>(number(json, "", "frames_emitted"));
    r.elapsed_s = number(json, "", "elapsed_s");
    if (r.frames <= 0 || r.elapsed_s <= 0.0) {
        r.error = "no frames in the run's statistics";
        return r;
    }
    r.fieldsPerSecondWholeRun = static_cast<double>(r.frames * r.fieldsPerFrame) / r.elapsed_s;
    // Steady state: the frames after the first warmFrames, as the metadata output saw them.
    const std::vector<double>& t = full.emitted_s;
    if (static_cast<int>(t.size()) != req.frames || req.frames - req.warmFrames < 2) {
        r.error = "the metadata output gave " + std::to_string(t.size()) + " lines for " +
                  std::to_string(req.frames) + " frames";
        return r;
    }
    std::vector<double> period;
    for (std::size_t i = static_cast<std::size_t>(req.warmFrames); i < t.size(); ++i)
        period.push_back(t[i] - t[i - 1]);
    r.fields_per_s = static_cast<double>(period.size()) * r.fieldsPerFrame /
                     (t.back() - t[static_cast<std::size_t>(req.warmFrames) - 1]);
    std::sort(period.begin(), period.end());
    const auto q = [&period](double p) {
        return period[std::min(period.size() - 1,
                               static_cast<std::size_t>(p * static_cast<double>(period.size())))];
    };
    r.period_p50_s = q(0.5);
    r.period_p99_s = q(0.99);
    r.overhead_p50_s = number(json, "overhead", "p50_s");
    r.overhead_p99_s = number(json, "overhead", "p99_s");
    r.frameTime_p50_s = number(json, "frame_time", "p50_s");
    r.frameTime_p99_s = number(json, "frame_time", "p99_s");
    r.peakRss_MiB = full.maxRss_MiB;
    r.allocationsCounted = allocationCounting();
    r.steadyAllocations = static_cast<std::int64_t>(full.windowAllocations);
    r.steadyFields = static_cast<std::int64_t>(req.frames - 2 - req.warmFrames) * r.fieldsPerFrame;
    r.cpuPerField_s =
        full.windowCpu_s / static_cast<double>(std::max<std::int64_t>(1, r.steadyFields));
    r.ok = true;
    return r;
}

std::string endToEndJson(const EndToEndRequest& req, const EndToEndResult& r) {
    std::string j = "{\"name\":\"" + jsonEscape(req.name) + "\",\"what\":\"" +
                    jsonEscape(req.what) + "\",\"scenario\":\"" +
                    jsonEscape(req.scenario.string()) + "\"";
    if (!r.ok) return j + ",\"error\":\"" + jsonEscape(r.error) + "\"}";
    char buf[1024];
    std::snprintf(
        buf, sizeof buf,
        ",\"frames\":%lld,\"fields_per_frame\":%d,\"elapsed_s\":%.6g,\"fields_per_s\":%.6g,"
        "\"fields_per_s_whole_run\":%.6g,"
        "\"target_fields_per_s\":%.6g,\"meets_target\":%s,\"field_period_p50_s\":%.6g,"
        "\"field_period_p99_s\":%.6g,\"frame_period_p50_s\":%.6g,\"frame_period_p99_s\":%.6g,"
        "\"frame_time_p50_s\":%.6g,\"frame_time_p99_s\":%.6g,\"loop_overhead_p50_s\":%.6g,"
        "\"loop_overhead_p99_s\":%.6g,\"peak_rss_mib\":%.6g,"
        "\"steady_fields\":%lld,\"cpu_s_per_field\":%.6g,",
        static_cast<long long>(r.frames), r.fieldsPerFrame, r.elapsed_s, r.fields_per_s,
        r.fieldsPerSecondWholeRun, req.targetFields_per_s,
        r.fields_per_s >= req.targetFields_per_s ? "true" : "false",
        r.period_p50_s / r.fieldsPerFrame, r.period_p99_s / r.fieldsPerFrame, r.period_p50_s,
        r.period_p99_s, r.frameTime_p50_s, r.frameTime_p99_s, r.overhead_p50_s, r.overhead_p99_s,
        r.peakRss_MiB, static_cast<long long>(r.steadyFields), r.cpuPerField_s);
    j += buf;
    if (r.allocationsCounted) {
        std::snprintf(buf, sizeof buf,
                      "\"steady_allocations\":%lld,\"allocations_per_field\":%.6g}",
                      static_cast<long long>(r.steadyAllocations),
                      static_cast<double>(r.steadyAllocations) /
                          static_cast<double>(std::max<std::int64_t>(1, r.steadyFields)));
        return j + buf;
    }
    return j + "\"steady_allocations\":null,\"allocations_per_field\":null}";
}

}  // namespace nvs::rt::bench
