#include "rt/bench/end_to_end.h"

#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <fstream>
#include <sstream>

#include "rt/bench/alloc_count.h"
#include "rt/bench/timed_items.h"
#include "rt/run/run.h"

namespace nvs::rt::bench {
namespace {

// What the child sends back through its pipe, then an error text when rc < 0.
struct ChildReport {
    int rc = -1;
    std::uint64_t allocations = 0;
};

struct ChildRun {
    bool ok = false;
    std::string error;
    std::uint64_t allocations = 0;
    double maxRss_MiB = 0.0;
};

[[noreturn]] void childMain(const EndToEndRequest& req, int frames,
                            const std::filesystem::path& stats, int fd) {
    ChildReport rep;
    std::string error;
    try {
        RunRequest run;
        run.scenario = req.scenario.string();
        run.outputs = {"y4m:/dev/null"};
        run.clock = ClockKind::Sim;
        run.frames = frames;
        run.statsPath = stats.string();
        run.dirs = req.dirs;
        std::FILE* quiet = std::fopen("/dev/null", "w");
        const std::uint64_t a0 = allocationCount();
        rep.rc = runScenario(run, quiet != nullptr ? quiet : stderr);
        rep.allocations = allocationCount() - a0;
        if (rep.rc != 0) error = "nvstim run exited with status " + std::to_string(rep.rc);
    } catch (const std::exception& e) {
        rep.rc = -1;
        error = e.what();
    }
    if (rep.rc != 0 && rep.rc != -1) rep.rc = -1;
    (void)!write(fd, &rep, sizeof rep);
    (void)!write(fd, error.data(), error.size());
    close(fd);
    _exit(0);
}

ChildRun runChild(const EndToEndRequest& req, int frames, const std::filesystem::path& stats) {
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
        childMain(req, frames, stats, fds[1]);
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
    if (bytes.size() < sizeof(ChildReport)) {
        out.error = "the run's process ended without a report (status " + std::to_string(status) +
                    ")";
        return out;
    }
    ChildReport rep;
    std::memcpy(&rep, bytes.data(), sizeof rep);
    out.ok = rep.rc == 0;
    out.error = bytes.substr(sizeof rep);
    out.allocations = rep.allocations;
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
    std::fprintf(stderr, "nvstim bench: %s: %d and %d frames under the sim clock ...\n",
                 req.name.c_str(), req.warmFrames, req.frames);
    const ChildRun warm = runChild(req, req.warmFrames, stats);
    const ChildRun full = warm.ok ? runChild(req, req.frames, stats) : warm;
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
    r.fields_per_s = static_cast<double>(r.frames * r.fieldsPerFrame) / r.elapsed_s;
    r.period_p50_s = number(json, "period", "p50_s");
    r.period_p99_s = number(json, "period", "p99_s");
    r.frameTime_p50_s = number(json, "frame_time", "p50_s");
    r.frameTime_p99_s = number(json, "frame_time", "p99_s");
    r.peakRss_MiB = full.maxRss_MiB;
    r.allocationsCounted = allocationCounting();
    r.steadyAllocations =
        static_cast<std::int64_t>(full.allocations) - static_cast<std::int64_t>(warm.allocations);
    r.steadyFields = static_cast<std::int64_t>(req.frames - req.warmFrames) * r.fieldsPerFrame;
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
        "\"target_fields_per_s\":%.6g,\"meets_target\":%s,\"field_period_p50_s\":%.6g,"
        "\"field_period_p99_s\":%.6g,\"frame_period_p50_s\":%.6g,\"frame_period_p99_s\":%.6g,"
        "\"frame_time_p50_s\":%.6g,\"frame_time_p99_s\":%.6g,\"peak_rss_mib\":%.6g,"
        "\"steady_fields\":%lld,",
        static_cast<long long>(r.frames), r.fieldsPerFrame, r.elapsed_s, r.fields_per_s,
        req.targetFields_per_s, r.fields_per_s >= req.targetFields_per_s ? "true" : "false",
        r.period_p50_s / r.fieldsPerFrame, r.period_p99_s / r.fieldsPerFrame, r.period_p50_s,
        r.period_p99_s, r.frameTime_p50_s, r.frameTime_p99_s, r.peakRss_MiB,
        static_cast<long long>(r.steadyFields));
    j += buf;
    if (r.allocationsCounted) {
        std::snprintf(buf, sizeof buf, "\"steady_allocations\":%lld,\"allocations_per_field\":%.6g}",
                      static_cast<long long>(r.steadyAllocations),
                      static_cast<double>(r.steadyAllocations) /
                          static_cast<double>(std::max<std::int64_t>(1, r.steadyFields)));
        return j + buf;
    }
    return j + "\"steady_allocations\":null,\"allocations_per_field\":null}";
}

}  // namespace nvs::rt::bench
