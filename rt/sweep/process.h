#pragma once
// The child processes of a sweep: workers (`nvstim sweep --task`), the jobs' programs, and
// Slurm's commands. Each child runs in its own process group, so that stopping it stops what
// it started too, and a terminal's Ctrl-C reaches only the sweep, which stops its children.

#include <sys/types.h>

#include <atomic>
#include <string>
#include <vector>

namespace nvs::rt::sweep {

struct SpawnSpec {
    std::vector<std::string> argv;  // argv[0] searched on PATH when it holds no '/'
    std::string cwd;                // "" : the caller's
    std::string stdoutFile;         // "" : /dev/null; else created or truncated
    std::string stderrFile;         // "" : /dev/null; may equal stdoutFile (one file)
};

// Starts the child in a new process group; returns its pid, or -errno where it could not be
// started (a missing program is reported by the child as exit status 127).
pid_t spawnChild(const SpawnSpec& spec);

// Status as a shell reports it: the exit status, or 128 + the signal that ended it.
int shellStatus(int waitStatus);

// Stops a child's process group: SIGTERM, then SIGKILL after `grace_s`; waits for it and
// returns its shellStatus.
int stopChild(pid_t pid, double grace_s);

struct ChildOutcome {
    int status = -1;  // shellStatus; -1 never started
    bool timedOut = false;
    bool stopped = false;  // `stop` was set
    double wall_s = 0.0;
};

// Starts the child and waits for it: stopped after `timeout_s`, or when `*stop` becomes true.
ChildOutcome runChildFor(const SpawnSpec& spec, double timeout_s, const std::atomic<bool>* stop);

// Runs a command to its end, its stdout and stderr returned (for sbatch, squeue); returns its
// shellStatus, or -1 where it could not be started.
int runCapture(const std::vector<std::string>& argv, std::string* out, std::string* err);

// The last `lines` non-empty lines of a file, joined by " | ", at most `maxBytes` bytes.
std::string fileTail(const std::string& path, int lines, std::size_t maxBytes);

// Catches SIGINT and SIGTERM for the process' lifetime, setting the flag returned (a sweep
// stops its children and ends with status 8).
std::atomic<bool>& installSweepStopSignals();

}  // namespace nvs::rt::sweep
