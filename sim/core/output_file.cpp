#include "sim/core/output_file.h"

#include <fcntl.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <random>
#include <stdexcept>
#include <system_error>

#include "sim/core/error.h"
#include "sim/core/input_file.h"

namespace nvs {

namespace fs = std::filesystem;

namespace {

// "OPTION PATH: why" (or "PATH: why" without an option): the one line of a setup error.
[[noreturn]] void refuse(const std::string& option, const fs::path& path, const std::string& why) {
    throw SetupError((option.empty() ? "" : option + " ") + path.string() + ": " + why);
}

[[noreturn]] void failed(const fs::path& path, const std::string& what, int err) {
    throw std::runtime_error(path.string() + ": " + what + ": " + std::strerror(err));
}

fs::path withoutTrailingSlashes(const fs::path& p) {
    std::string s = p.string();
    while (s.size() > 1 && s.back() == '/')
        s.pop_back();
    return s.empty() ? fs::path(".") : fs::path(s);
}

// The absolute path with its folder resolved (symbolic links, "." and ".."); for a path that
// exists and is a folder, or ends in "." or "..", the whole of it resolved.
fs::path keyOf(const fs::path& given) {
    std::error_code ec;
    const fs::path p = fs::absolute(withoutTrailingSlashes(given), ec);
    const fs::path name = p.filename();
    struct stat st {};
    if (name.empty() || name == "." || name == ".." ||
        (::stat(p.c_str(), &st) == 0 && S_ISDIR(st.st_mode))) {
        const fs::path k = fs::weakly_canonical(p, ec);
        return ec ? p.lexically_normal() : k;
    }
    const fs::path parent = fs::weakly_canonical(p.parent_path(), ec);
    return (ec ? p.parent_path().lexically_normal() : parent) / name;
}

// Whether `inner` is `outer` or lies inside it (both keys).
bool within(const fs::path& outer, const fs::path& inner) {
    auto o = outer.begin();
    auto i = inner.begin();
    for (; o != outer.end(); ++o, ++i)
        if (i == inner.end() || *o != *i) return false;
    return true;
}

std::string randomSuffix() {
    static std::mt19937_64 gen{std::random_device{}() ^
                               static_cast<std::uint64_t>(::getpid()) << 32 ^
                               static_cast<std::uint64_t>(std::time(nullptr))};
    static const char kChars[] = "abcdefghijklmnopqrstuvwxyz0123456789";
    std::string s(8, 'x');
    for (char& c : s)
        c = kChars[gen() % (sizeof kChars - 1)];
    return s;
}

// A new file or folder beside `final`, never one that was there (O_EXCL: a name taken by a
// file or a symbolic link is skipped). Returns its path; errno in `err` on failure.
fs::path createTemporary(const fs::path& final, bool folder, int& err) {
    const fs::path dir = final.parent_path().empty() ? fs::path(".") : final.parent_path();
    // Within NAME_MAX (255) with the 21 characters added.
    std::string base = final.filename().string();
    if (base.size() > 200) base.resize(200);
    for (int attempt = 0; attempt < 64; ++attempt) {
        fs::path t = dir / (base + ".nvstim-" + randomSuffix() + ".tmp");
        if (folder) {
            if (::mkdir(t.c_str(), 0777) == 0) return t;
        } else {
            const int fd =
                ::open(t.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
            if (fd >= 0) {
                ::close(fd);
                return t;
            }
        }
        if (errno != EEXIST) {
            err = errno;
            return {};
        }
    }
    err = EEXIST;
    return {};
}

bool holdsMarker(const fs::path& dir, const std::string& marker) {
    struct stat st {};
    return ::lstat((dir / marker).c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

int fsyncPath(const fs::path& p, int flags) {
    const int fd = ::open(p.c_str(), O_RDONLY | O_CLOEXEC | O_NOFOLLOW | flags);
    if (fd < 0) return errno;
    int err = ::fsync(fd) != 0 && errno != EINVAL ? errno : 0;
    if (::close(fd) != 0 && err == 0) err = errno;
    return err;
}

const int kHeld[] = {SIGINT, SIGTERM, SIGHUP, SIGQUIT};

sigset_t heldSet() {
    sigset_t s;
    sigemptyset(&s);
    for (int sig : kHeld)
        sigaddset(&s, sig);
    return s;
}

}  // namespace

// ---- OutputFiles -------------------------------------------------------------------------------

OutputFiles::~OutputFiles() {
    discard();
    hold_.reset();  // a held signal is delivered only now, with nothing left behind
}

void OutputFiles::addInput(const fs::path& path) {
    struct stat st {};
    if (path.empty() || ::stat(path.c_str(), &st) != 0) return;
    const fs::path key = keyOf(path);
    const bool folder = S_ISDIR(st.st_mode);
    const FileId id{st.st_dev, st.st_ino};
    for (const auto* hit : {outputIndex_.count(key) ? &outputs_[outputIndex_.at(key)] : nullptr,
                            outputIds_.count(id) ? &outputs_[outputIds_.at(id)] : nullptr})
        if (hit != nullptr) refuse(hit->option, hit->path, "is the input " + path.string());
    for (std::size_t i : folderOutputs_)
        if (within(outputs_[i].key, key))
            refuse(outputs_[i].option, outputs_[i].path, "holds the input " + path.string());
    if (folder) {
        for (const Output& o : outputs_)
            if (within(key, o.key))
                refuse(o.option, o.path, "lies inside the input folder " + path.string());
        inputFolders_.push_back(key);
    }
    inputKeys_.insert(key);
    inputIds_.insert(id);
}

void OutputFiles::checkAgainst(const Output& o, const FileId* id) const {
    if (auto it = outputIndex_.find(o.key); it != outputIndex_.end())
        refuse(o.option, o.path, "is also the output of " + outputs_[it->second].option);
    if (id != nullptr)
        if (auto it = outputIds_.find(*id); it != outputIds_.end())
            refuse(o.option, o.path, "is also the output of " + outputs_[it->second].option);
    for (std::size_t i : folderOutputs_)
        if (within(outputs_[i].key, o.key))
            refuse(o.option, o.path, "lies inside the folder of " + outputs_[i].option);
    if (o.folder)
        for (const Output& other : outputs_)
            if (within(o.key, other.key))
                refuse(o.option, o.path, "holds the output of " + other.option);
    if (inputKeys_.count(o.key) != 0 || (id != nullptr && inputIds_.count(*id) != 0))
        refuse(o.option, o.path, "is an input of this command");
    for (const fs::path& in : inputFolders_)
        if (within(in, o.key))
            refuse(o.option, o.path, "lies inside the input folder " + in.string());
    if (o.folder)
        for (const fs::path& in : inputKeys_)
            if (within(o.key, in))
                refuse(o.option, o.path, "holds an input of this command (" + in.string() + ")");
}

void OutputFiles::add(Output o) {
    outputIndex_.emplace(o.key, outputs_.size());
    if (o.folder) folderOutputs_.push_back(outputs_.size());
    struct stat st {};
    if (!o.folder && ::stat(o.path.c_str(), &st) == 0)
        outputIds_.emplace(FileId{st.st_dev, st.st_ino}, outputs_.size());
    outputs_.push_back(std::move(o));
}

void OutputFiles::addFile(const std::string& option, const fs::path& path) {
    const std::string s = path.string();
    if (s.empty()) refuse(option, path, "empty path");
    if (s == "-") refuse(option, path, "'-' names no file here (name a file)");
    if (s.back() == '/') refuse(option, path, "names a folder; a file is due");
    struct stat st {};
    bool exists = false;
    if (::lstat(path.c_str(), &st) == 0) {
        if (S_ISLNK(st.st_mode) && ::stat(path.c_str(), &st) != 0 && errno == ELOOP)
            refuse(option, path, "a loop of symbolic links");
        if (S_ISDIR(st.st_mode)) refuse(option, path, "is a folder; a file is due");
        if (!S_ISREG(st.st_mode) && !S_ISLNK(st.st_mode))
            refuse(option, path, std::string(kindOf(st.st_mode)) + ", not a regular file");
        exists = S_ISREG(st.st_mode);
    } else if (errno == ELOOP || errno == ENAMETOOLONG || errno == ENOTDIR) {
        refuse(option, path, std::strerror(errno));
    }
    const FileId id{st.st_dev, st.st_ino};
    Output o{option, path, keyOf(path), {}, false, {}, 0, 0};
    const fs::path dir = o.key.parent_path();
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
        refuse(option, path, "no folder " + path.parent_path().string());
    checkAgainst(o, exists ? &id : nullptr);
    // The folder takes a new file: create one, remove it (once per folder).
    if (probedFolders_.count(dir) == 0) {
        int err = 0;
        const fs::path probe = createTemporary(o.key, false, err);
        if (probe.empty()) {
            refuse(option, path,
                   "cannot create a file in " + dir.string() + ": " + std::strerror(err));
        }
        ::unlink(probe.c_str());
        probedFolders_.insert(dir);
    }
    add(std::move(o));
}

void OutputFiles::checkFolderTarget(const Output& o) const {
    std::error_code ec;
    const fs::path cwd = fs::weakly_canonical(fs::current_path(ec), ec);
    if (!cwd.empty() && within(o.key, cwd))
        refuse(o.option, o.path, "is or holds the current folder; name a new folder");
    struct stat st {};
    if (::lstat(o.path.c_str(), &st) == 0) {
        if (S_ISLNK(st.st_mode)) refuse(o.option, o.path, "a symbolic link; name a new folder");
        if (!S_ISDIR(st.st_mode))
            refuse(o.option, o.path, std::string(kindOf(st.st_mode)) + ", not a folder");
        if (!holdsMarker(o.path, o.marker)) {
            refuse(o.option, o.path,
                   "exists and is not an nvstim output (no " + o.marker +
                       " in it); name a new folder");
        }
    } else if (errno != ENOENT) {
        refuse(o.option, o.path, std::strerror(errno));
    }
}

void OutputFiles::addFolder(const std::string& option, const fs::path& path,
                            const std::string& marker) {
    Output o{option, withoutTrailingSlashes(path), keyOf(path), marker, true, {}, 0, 0};
    checkAgainst(o, nullptr);
    checkFolderTarget(o);
    const fs::path dir = o.key.parent_path();
    struct stat st {};
    if (::stat(dir.c_str(), &st) != 0 || !S_ISDIR(st.st_mode))
        refuse(option, o.path, "no folder " + dir.string());
    int err = 0;
    const fs::path probe = createTemporary(o.key, true, err);
    if (probe.empty()) {
        refuse(option, o.path,
               "cannot create a folder in " + dir.string() + ": " + std::strerror(err));
    }
    ::rmdir(probe.c_str());
    add(std::move(o));
}

OutputFiles::Output& OutputFiles::find(const fs::path& path) {
    const auto it = outputIndex_.find(keyOf(path));
    if (it == outputIndex_.end()) throw std::logic_error(path.string() + ": not a declared output");
    return outputs_[it->second];
}

fs::path OutputFiles::stage(const fs::path& path) {
    Output& o = find(path);
    if (!o.temp.empty()) throw std::logic_error(path.string() + ": staged twice");
    int err = 0;
    // The temporary lies beside the final path as it resolved at setup.
    fs::path t = createTemporary(o.key, o.folder, err);
    if (t.empty()) failed(o.path, "cannot create a temporary beside it", err);
    struct stat st {};
    if (::lstat(t.c_str(), &st) != 0) failed(t, "cannot stat", errno);
    o.temp = t;
    o.dev = st.st_dev;
    o.ino = st.st_ino;
    if (o.folder) {
        const int fd = ::open((t / o.marker).c_str(),
                              O_WRONLY | O_CREAT | O_EXCL | O_NOFOLLOW | O_CLOEXEC, 0666);
        if (fd < 0 || ::close(fd) != 0) failed(t / o.marker, "cannot create", errno);
    }
    return t;
}

void OutputFiles::writeText(const fs::path& path, std::string_view text) {
    const fs::path t = stage(path);
    const int fd = ::open(t.c_str(), O_WRONLY | O_TRUNC | O_NOFOLLOW | O_CLOEXEC);
    if (fd < 0) failed(t, "cannot open", errno);
    const char* p = text.data();
    std::size_t left = text.size();
    while (left > 0) {
        const ssize_t n = ::write(fd, p, left);
        if (n < 0 && errno == EINTR) continue;
        if (n <= 0) {
            const int e = n < 0 ? errno : EIO;
            ::close(fd);
            failed(path, "write failed", e);
        }
        p += n;
        left -= static_cast<std::size_t>(n);
    }
    if (::close(fd) != 0) failed(path, "close failed", errno);
}

void OutputFiles::commit() {
    if (SignalHold::pending()) {
        discard();
        throw std::runtime_error("interrupted by a signal; no output written");
    }
    // Every temporary durable and still the one created, before any final path is touched.
    for (Output& o : outputs_) {
        if (o.temp.empty()) continue;
        struct stat st {};
        if (::lstat(o.temp.c_str(), &st) != 0 || st.st_dev != o.dev || st.st_ino != o.ino) {
            o.temp.clear();  // not ours any more: left alone
            discard();
            throw std::runtime_error(o.path.string() + ": its temporary was replaced meanwhile");
        }
        int err = 0;
        if (o.folder) {
            std::error_code ec;
            for (const auto& e : fs::recursive_directory_iterator(o.temp, ec)) {
                if (err == 0 && e.is_regular_file(ec) && !e.is_symlink(ec))
                    err = fsyncPath(e.path(), 0);
            }
            if (ec && err == 0) err = ec.value();
            if (err == 0) err = fsyncPath(o.temp, O_DIRECTORY);
        } else {
            err = fsyncPath(o.temp, 0);
        }
        if (err != 0) {
            discard();
            failed(o.path, "cannot make it durable", err);
        }
    }
    for (Output& o : outputs_) {
        if (o.temp.empty()) continue;
        if (o.folder) {
            struct stat st {};
            const bool replacing = ::lstat(o.key.c_str(), &st) == 0;
            if (replacing && (!S_ISDIR(st.st_mode) || !holdsMarker(o.key, o.marker))) {
                discard();
                throw std::runtime_error(o.path.string() + ": changed meanwhile; not replaced");
            }
            if (::renameat2(AT_FDCWD, o.temp.c_str(), AT_FDCWD, o.key.c_str(),
                            replacing ? RENAME_EXCHANGE : RENAME_NOREPLACE) != 0) {
                const int e = errno;
                discard();
                failed(o.path, "cannot move the output into place", e);
            }
            // The temporary's name now holds the previous report: removed, with its marker.
            std::error_code ec;
            if (replacing) fs::remove_all(o.temp, ec);
        } else {
            struct stat st {};
            if (::stat(o.key.c_str(), &st) == 0 && !S_ISREG(st.st_mode)) {
                discard();
                throw std::runtime_error(o.path.string() + ": became " + kindOf(st.st_mode) +
                                         " meanwhile; not replaced");
            }
            if (::rename(o.temp.c_str(), o.key.c_str()) != 0) {
                const int e = errno;
                discard();
                failed(o.path, "cannot move the output into place", e);
            }
        }
        o.temp.clear();
        (void)fsyncPath(o.key.parent_path(), O_DIRECTORY);
    }
}

void OutputFiles::discard() noexcept {
    for (Output& o : outputs_) {
        if (o.temp.empty()) continue;
        struct stat st {};
        if (::lstat(o.temp.c_str(), &st) == 0 && st.st_dev == o.dev && st.st_ino == o.ino) {
            std::error_code ec;
            if (o.folder)
                fs::remove_all(o.temp, ec);
            else
                ::unlink(o.temp.c_str());
        }
        o.temp.clear();
    }
}

// ---- SignalHold, runChild ----------------------------------------------------------------------

namespace {

volatile std::sig_atomic_t gHeldSignal = 0;
std::atomic<bool> gHolding{false};

extern "C" void noteSignal(int sig) {
    gHeldSignal = sig;
}

}  // namespace

SignalHold::SignalHold() {
    if (gHolding.exchange(true)) throw std::logic_error("SignalHold: one at a time");
    gHeldSignal = 0;
    struct sigaction sa {};
    sa.sa_handler = noteSignal;
    sigemptyset(&sa.sa_mask);
    sa.sa_flags = SA_RESTART;
    for (int i = 0; i < 4; ++i) {
        ::sigaction(kHeld[i], nullptr, &old_[i]);
        // A signal the process ignores (nohup, a background job's SIGINT) stays ignored.
        if (old_[i].sa_handler != SIG_IGN) ::sigaction(kHeld[i], &sa, nullptr);
    }
}

SignalHold::~SignalHold() {
    for (int i = 0; i < 4; ++i)
        ::sigaction(kHeld[i], &old_[i], nullptr);
    const int sig = gHeldSignal;
    gHeldSignal = 0;
    gHolding.store(false);
    if (sig != 0) ::raise(sig);
}

bool SignalHold::pending() noexcept {
    return gHolding.load() && gHeldSignal != 0;
}

int runChild(const std::vector<std::string>& argv) {
    if (argv.empty()) return -1;
    std::vector<char*> args;
    args.reserve(argv.size() + 1);
    for (const std::string& a : argv)
        args.push_back(const_cast<char*>(a.c_str()));
    args.push_back(nullptr);
    const pid_t pid = ::fork();
    if (pid < 0) return -1;
    if (pid == 0) {
        // The child starts with the usual dispositions (a caught signal's handler is reset by
        // exec; a blocked one would stay blocked).
        const sigset_t held = heldSet();
        ::pthread_sigmask(SIG_UNBLOCK, &held, nullptr);
        ::execvp(args[0], args.data());
        ::_exit(127);
    }
    for (;;) {
        int status = 0;
        const pid_t w = ::waitpid(pid, &status, WNOHANG);
        if (w == pid) return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
        if (w < 0 && errno != EINTR) return -1;
        if (SignalHold::pending()) {
            ::kill(pid, SIGTERM);
            while (::waitpid(pid, &status, 0) < 0 && errno == EINTR) {
            }
            return -1;
        }
        const timespec slice{0, 20'000'000};
        ::nanosleep(&slice, nullptr);
    }
}

// ---- OutputFiles' hold -------------------------------------------------------------------------

void OutputFiles::holdSignals() {
    if (!hold_) hold_.emplace();
}

}  // namespace nvs
