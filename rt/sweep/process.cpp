#include "rt/sweep/process.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <csignal>
#include <fstream>
#include <sstream>
#include <thread>

extern char** environ;

namespace nvs::rt::sweep {

namespace {

using Clock = std::chrono::steady_clock;

double secondsSince(Clock::time_point t0) {
    return std::chrono::duration<double>(Clock::now() - t0).count();
}

std::atomic<bool> gStop{false};

void onStopSignal(int) {
    gStop.store(true);
}

// Reads a whole file ("" when it cannot).
std::string slurp(const std::string& path) {
    std::ifstream in(path, std::ios::binary);
    std::ostringstream s;
    s << in.rdbuf();
    return s.str();
}

}  // namespace

pid_t spawnChild(const SpawnSpec& spec) {
    posix_spawn_file_actions_t fa;
    posix_spawnattr_t attr;
    posix_spawn_file_actions_init(&fa);
    posix_spawnattr_init(&attr);
    // Not O_CLOEXEC: the descriptor opened is the child's stdout or stderr across exec.
    const int flags = O_WRONLY | O_CREAT | O_TRUNC;
    posix_spawn_file_actions_addopen(&fa, STDIN_FILENO, "/dev/null", O_RDONLY, 0);
    const std::string out = spec.stdoutFile.empty() ? "/dev/null" : spec.stdoutFile;
    const std::string err = spec.stderrFile.empty() ? "/dev/null" : spec.stderrFile;
    posix_spawn_file_actions_addopen(&fa, STDOUT_FILENO, out.c_str(), flags, 0644);
    if (err == out) {
        posix_spawn_file_actions_adddup2(&fa, STDOUT_FILENO, STDERR_FILENO);
    } else {
        posix_spawn_file_actions_addopen(&fa, STDERR_FILENO, err.c_str(), flags, 0644);
    }
    if (!spec.cwd.empty()) posix_spawn_file_actions_addchdir_np(&fa, spec.cwd.c_str());
    // Its own process group (0: the child's pid), and the default handlers of the signals
    // this process catches.
    sigset_t defaults;
    sigemptyset(&defaults);
    sigaddset(&defaults, SIGINT);
    sigaddset(&defaults, SIGTERM);
    sigaddset(&defaults, SIGPIPE);
    posix_spawnattr_setsigdefault(&attr, &defaults);
    posix_spawnattr_setpgroup(&attr, 0);
    posix_spawnattr_setflags(&attr, POSIX_SPAWN_SETPGROUP | POSIX_SPAWN_SETSIGDEF);
    std::vector<char*> argv;
    for (const std::string& a : spec.argv)
        argv.push_back(const_cast<char*>(a.c_str()));
    argv.push_back(nullptr);
    pid_t pid = -1;
    const int rc = posix_spawnp(&pid, argv[0], &fa, &attr, argv.data(), environ);
    posix_spawn_file_actions_destroy(&fa);
    posix_spawnattr_destroy(&attr);
    return rc == 0 ? pid : -rc;
}

int shellStatus(int waitStatus) {
    if (WIFEXITED(waitStatus)) return WEXITSTATUS(waitStatus);
    if (WIFSIGNALED(waitStatus)) return 128 + WTERMSIG(waitStatus);
    return -1;
}

int stopChild(pid_t pid, double grace_s) {
    ::kill(-pid, SIGTERM);
    const auto t0 = Clock::now();
    int ws = 0;
    for (;;) {
        const pid_t r = ::waitpid(pid, &ws, WNOHANG);
        if (r == pid) break;
        if (r < 0 && errno != EINTR) return -1;
        if (secondsSince(t0) > grace_s) {
            ::kill(-pid, SIGKILL);
            while (::waitpid(pid, &ws, 0) < 0 && errno == EINTR) {
            }
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    // Whatever of its group is left (a grandchild that ignored SIGTERM).
    ::kill(-pid, SIGKILL);
    return shellStatus(ws);
}

ChildOutcome runChildFor(const SpawnSpec& spec, double timeout_s, const std::atomic<bool>* stop) {
    ChildOutcome o;
    const auto t0 = Clock::now();
    const pid_t pid = spawnChild(spec);
    if (pid < 0) return o;
    int ws = 0;
    for (;;) {
        const pid_t r = ::waitpid(pid, &ws, WNOHANG);
        if (r == pid) {
            o.status = shellStatus(ws);
            break;
        }
        if (r < 0 && errno != EINTR) break;
        if (stop != nullptr && stop->load()) {
            o.stopped = true;
            o.status = stopChild(pid, 5.0);
            break;
        }
        if (secondsSince(t0) > timeout_s) {
            o.timedOut = true;
            o.status = stopChild(pid, 5.0);
            break;
        }
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    o.wall_s = secondsSince(t0);
    return o;
}

int runCapture(const std::vector<std::string>& argv, std::string* out, std::string* err) {
    char outName[] = "/tmp/nvstim-sweep-outXXXXXX";
    char errName[] = "/tmp/nvstim-sweep-errXXXXXX";
    const int fo = ::mkstemp(outName);
    const int fe = ::mkstemp(errName);
    if (fo >= 0) ::close(fo);
    if (fe >= 0) ::close(fe);
    int status = -1;
    if (fo >= 0 && fe >= 0) {
        const ChildOutcome o = runChildFor({argv, "", outName, errName}, 600.0, nullptr);
        status = o.status;
        if (out != nullptr) *out = slurp(outName);
        if (err != nullptr) *err = slurp(errName);
    }
    if (fo >= 0) ::unlink(outName);
    if (fe >= 0) ::unlink(errName);
    return status;
}

std::string fileTail(const std::string& path, int lines, std::size_t maxBytes) {
    const std::string text = slurp(path);
    std::vector<std::string> kept;
    std::size_t end = text.size();
    while (end > 0 && static_cast<int>(kept.size()) < lines) {
        std::size_t start = text.rfind('\n', end - 1);
        start = start == std::string::npos ? 0 : start + 1;
        std::string line = text.substr(start, end - start);
        while (!line.empty() && (line.back() == '\r' || line.back() == '\n'))
            line.pop_back();
        if (!line.empty()) kept.insert(kept.begin(), line);
        if (start == 0) break;
        end = start - 1;
    }
    std::string joined;
    for (const std::string& l : kept)
        joined += (joined.empty() ? "" : " | ") + l;
    if (joined.size() > maxBytes) joined = "..." + joined.substr(joined.size() - maxBytes);
    return joined;
}

std::atomic<bool>& installSweepStopSignals() {
    struct sigaction sa {};
    sa.sa_handler = onStopSignal;
    sigemptyset(&sa.sa_mask);
    ::sigaction(SIGINT, &sa, nullptr);
    ::sigaction(SIGTERM, &sa, nullptr);
    return gStop;
}

}  // namespace nvs::rt::sweep
