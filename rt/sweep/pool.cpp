#include "rt/sweep/pool.h"

#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <map>
#include <thread>

#include "rt/sweep/process.h"
#include "rt/sweep/task.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

namespace {

double nowSeconds() {
    return std::chrono::duration<double>(std::chrono::steady_clock::now().time_since_epoch())
        .count();
}

// "1 h 02 min", "3 min 05 s", "12 s".
std::string duration(double s) {
    char buf[40];
    const long long t = static_cast<long long>(s + 0.5);
    if (t >= 3600) {
        std::snprintf(buf, sizeof buf, "%lld h %02lld min", t / 3600, (t / 60) % 60);
    } else if (t >= 60) {
        std::snprintf(buf, sizeof buf, "%lld min %02lld s", t / 60, t % 60);
    } else {
        std::snprintf(buf, sizeof buf, "%lld s", t);
    }
    return buf;
}

// A worker that left no result: its job is recorded failed with what the worker said.
void recordLostWorker(const Job& job, int status) {
    if (!readResult(job).isNull()) return;
    Json r = Json::object();
    r.set("index", Json::number(static_cast<double>(job.index)));
    r.set("host", Json::string(hostName()));
    r.set("exit_status", Json::number(status));
    r.set("wall_s", Json());
    r.set("status", Json::string("failed"));
    const std::string tail = fileTail((fs::path(job.dir) / "task.log").string(), 3, 400);
    r.set("error", Json::string("the worker ended without a result (status " +
                                std::to_string(status) + ")" + (tail.empty() ? "" : ": " + tail)));
    writeResult(job, r);
}

}  // namespace

Progress::Progress(std::FILE* out, std::int64_t total, std::int64_t doneBefore)
    : out_(out),
      total_(total),
      before_(doneBefore),
      start_s_(nowSeconds()),
      tty_(out != nullptr && ::isatty(::fileno(out)) != 0) {}

void Progress::update(std::int64_t doneNow, std::int64_t failed, bool force) {
    if (out_ == nullptr) return;
    const double t = nowSeconds();
    if (!force && last_s_ >= 0.0 && t - last_s_ < 1.0) return;
    // Into a file or a pipe (a log, Slurm's output), a line when a job has finished, else
    // every 30 s; on a terminal, the line rewritten every second.
    if (!force && !tty_ && last_s_ >= 0.0 && doneNow == lastDone_ && t - last_s_ < 30.0) return;
    last_s_ = t;
    lastDone_ = doneNow;
    const double elapsed = t - start_s_;
    const double rate = elapsed > 0.0 ? static_cast<double>(doneNow) / elapsed : 0.0;
    const std::int64_t done = before_ + doneNow;
    std::string left = "time left unknown";
    if (done >= total_) {
        left = "took " + duration(elapsed);
    } else if (rate > 0.0) {
        left = duration(static_cast<double>(total_ - done) / rate) + " left";
    }
    char failedText[48] = "";
    if (failed > 0)
        std::snprintf(failedText, sizeof failedText, " (%lld failed)",
                      static_cast<long long>(failed));
    std::fprintf(out_, "%snvstim sweep: %lld/%lld done%s, %.2f jobs/s, %s%s", tty_ ? "\r" : "",
                 static_cast<long long>(done), static_cast<long long>(total_), failedText, rate,
                 left.c_str(), tty_ ? "\x1b[K" : "\n");
    if (tty_ && force) std::fprintf(out_, "\n");
    std::fflush(out_);
}

PoolResult runPool(const std::vector<Job>& jobs, const std::vector<std::int64_t>& todo, int workers,
                   const fs::path& nvstim, const fs::path& manifest, std::FILE* progress,
                   std::atomic<bool>& stop) {
    PoolResult res;
    Progress line(progress, static_cast<std::int64_t>(jobs.size()),
                  static_cast<std::int64_t>(jobs.size() - todo.size()));
    std::map<pid_t, std::int64_t> running;  // worker → job index
    std::size_t next = 0;
    line.update(0, 0, true);
    while (next < todo.size() || !running.empty()) {
        while (!stop.load() && next < todo.size() && static_cast<int>(running.size()) < workers) {
            const Job& job = jobs[static_cast<std::size_t>(todo[next++])];
            std::error_code ec;
            fs::create_directories(job.dir, ec);
            SpawnSpec w;
            w.argv = {nvstim.string(),           "sweep",      "--task",
                      std::to_string(job.index), "--manifest", manifest.string()};
            w.stdoutFile = (fs::path(job.dir) / "task.log").string();
            w.stderrFile = w.stdoutFile;
            const pid_t pid = spawnChild(w);
            if (pid < 0) {
                recordLostWorker(job, -1);
                ++res.ran;
                ++res.failed;
                continue;
            }
            running[pid] = job.index;
        }
        if (stop.load() && !running.empty()) {
            // Ctrl-C or SIGTERM: every worker stopped (they leave no result: a resume runs
            // their jobs again).
            for (const auto& [pid, index] : running)
                ::kill(-pid, SIGTERM);
            for (const auto& [pid, index] : running)
                stopChild(pid, 10.0);
            running.clear();
            res.interrupted = true;
            break;
        }
        if (stop.load() && running.empty()) {
            res.interrupted = next < todo.size();
            break;
        }
        int ws = 0;
        const pid_t pid = ::waitpid(-1, &ws, WNOHANG);
        if (pid > 0 && running.count(pid) != 0) {
            const Job& job = jobs[static_cast<std::size_t>(running[pid])];
            running.erase(pid);
            const int status = shellStatus(ws);
            if (status != kTaskOk && status != kTaskJobFailed) recordLostWorker(job, status);
            const Json r = readResult(job);
            ++res.ran;
            if (r.stringOr("status", "") != "ok") ++res.failed;
            line.update(res.ran, res.failed, false);
            continue;
        }
        if (pid < 0 && errno == ECHILD) running.clear();
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        line.update(res.ran, res.failed, false);
    }
    line.update(res.ran, res.failed, true);
    return res;
}

}  // namespace nvs::rt::sweep
