#include "rt/sweep/slurm.h"

#include <chrono>
#include <stdexcept>
#include <thread>

#include "rt/sweep/pool.h"
#include "rt/sweep/process.h"
#include "rt/sweep/task.h"
#include "sim/core/error.h"

namespace nvs::rt::sweep {

namespace fs = std::filesystem;

namespace {

// A word for a POSIX shell script, single-quoted.
std::string shellQuote(const std::string& s) {
    std::string out = "'";
    for (const char c : s)
        out += c == '\'' ? std::string("'\\''") : std::string(1, c);
    return out + "'";
}

std::string trimmed(std::string s) {
    while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ' '))
        s.pop_back();
    return s;
}

}  // namespace

std::string arrayRanges(const std::vector<std::int64_t>& indices) {
    std::string out;
    for (std::size_t i = 0; i < indices.size();) {
        std::size_t j = i;
        while (j + 1 < indices.size() && indices[j + 1] == indices[j] + 1)
            ++j;
        out += (out.empty() ? "" : ",") + std::to_string(indices[i]);
        if (j > i) out += "-" + std::to_string(indices[j]);
        i = j + 1;
    }
    return out;
}

std::string sbatchScript(const std::string& name, const std::vector<std::int64_t>& todo,
                         std::optional<int> throttle, const fs::path& nvstim, const fs::path& dir,
                         const fs::path& cwd) {
    std::string s = "#!/bin/sh\n";
    s += "# nvstim sweep: one array task per job of the manifest (docs/sweep.md, \"Slurm\").\n";
    s += "#SBATCH --job-name=nvstim-sweep-" + name + "\n";
    s += "#SBATCH --array=" + arrayRanges(todo) +
         (throttle ? "%" + std::to_string(*throttle) : std::string()) + "\n";
    s += "#SBATCH --output=" + (dir / "slurm" / "task-%a.out").string() + "\n";
    s += "#SBATCH --chdir=" + cwd.string() + "\n";
    s += "#SBATCH --ntasks=1\n";
    s += "exec " + shellQuote(nvstim.string()) +
         " sweep --task \"$SLURM_ARRAY_TASK_ID\" --manifest " +
         shellQuote((dir / "manifest.jsonl").string()) + "\n";
    return s;
}

std::vector<std::string> splitArgs(const std::string& text) {
    std::vector<std::string> out;
    std::string cur;
    bool any = false;
    char quote = 0;
    for (const char c : text) {
        if (quote != 0) {
            if (c == quote) {
                quote = 0;
            } else {
                cur += c;
            }
        } else if (c == '\'' || c == '"') {
            quote = c;
            any = true;
        } else if (c == ' ' || c == '\t' || c == '\n') {
            if (any) out.push_back(cur);
            cur.clear();
            any = false;
        } else {
            cur += c;
            any = true;
        }
    }
    if (quote != 0) throw SetupError("--sbatch-args: an unclosed quote in \"" + text + "\"");
    if (any) out.push_back(cur);
    return out;
}

std::string submitArray(const fs::path& script, const std::vector<std::string>& args) {
    std::vector<std::string> argv = {"sbatch", "--parsable"};
    argv.insert(argv.end(), args.begin(), args.end());
    argv.push_back(script.string());
    std::string out, err;
    const int rc = runCapture(argv, &out, &err);
    if (rc != 0) {
        throw std::runtime_error("sbatch failed (status " + std::to_string(rc) +
                                 (rc == 127 ? ": not found on PATH" : "") + "): " + trimmed(err));
    }
    // --parsable: "ID" or "ID;CLUSTER".
    std::string id = trimmed(out);
    const auto semi = id.find(';');
    if (semi != std::string::npos) id = id.substr(0, semi);
    if (id.empty() || id.find_first_not_of("0123456789") != std::string::npos) {
        throw std::runtime_error("sbatch printed no job id: \"" + trimmed(out) + "\"");
    }
    return id;
}

bool waitForArray(const std::string& id, const std::vector<Job>& jobs,
                  const std::vector<std::int64_t>& todo, std::FILE* progress,
                  std::atomic<bool>& stop) {
    Progress line(progress, static_cast<std::int64_t>(jobs.size()),
                  static_cast<std::int64_t>(jobs.size() - todo.size()));
    const auto count = [&](std::int64_t* failed) {
        std::int64_t done = 0;
        *failed = 0;
        for (const std::int64_t i : todo) {
            const Json r = readResult(jobs[static_cast<std::size_t>(i)]);
            if (r.isNull()) continue;
            ++done;
            if (r.stringOr("status", "") != "ok") ++*failed;
        }
        return done;
    };
    int failures = 0;
    for (;;) {
        for (int i = 0; i < 20 && !stop.load(); ++i)
            std::this_thread::sleep_for(std::chrono::milliseconds(100));
        std::int64_t failed = 0;
        const std::int64_t done = count(&failed);
        if (stop.load()) {
            std::string out, err;
            runCapture({"scancel", id}, &out, &err);
            line.update(done, failed, true);
            return false;
        }
        std::string out, err;
        const int rc =
            runCapture({"squeue", "--noheader", "--jobs", id, "--format", "%i"}, &out, &err);
        // squeue forgets a finished job after MinJobAge and then calls its id invalid.
        const bool gone = (rc == 0 && trimmed(out).empty()) ||
                          (rc != 0 && err.find("Invalid job id") != std::string::npos);
        if (gone) {
            line.update(count(&failed), failed, true);
            return true;
        }
        if (rc != 0 && ++failures > 30) {
            throw std::runtime_error("squeue keeps failing (status " + std::to_string(rc) +
                                     "): " + trimmed(err));
        }
        if (rc == 0) failures = 0;
        line.update(done, failed, false);
    }
}

}  // namespace nvs::rt::sweep
