#pragma once
// Writing a command's outputs without ever destroying a user's data (docs/reliability-inputs.md
// "Outputs"). One OutputFiles per command:
//
//  1. At setup, before any work, every output is declared (addFile, addFolder) and every input
//     it must not replace (addInput). Each path is checked then: a file output's folder exists
//     and takes a new file (probed by creating and removing one), the path is not a folder, a
//     device, a FIFO or "-"; a folder output is new, or a previous output of the same kind
//     (it holds the marker file), and never the current folder, an input or a folder holding
//     one; every output is distinct from the others and from every input. A failed check
//     throws SetupError naming the option and the path (one line, exit status 2).
//  2. At the end, each output is staged: stage() creates a unique temporary beside the final
//     path (O_CREAT|O_EXCL|O_NOFOLLOW, so an existing file or a symbolic link there is never
//     followed nor reused) and the caller writes it by name; writeText() does both.
//  3. commit() checks that each temporary is still the file it created, fsyncs and closes it
//     (errors are failures), then renames them all into place (a folder replaces the previous
//     report with one atomic exchange). Until then, and on any failure, nothing final is
//     touched, and the destructor removes every temporary: all outputs or none.
//
// While outputs are staged (holdSignals), SIGINT, SIGTERM, SIGHUP and SIGQUIT are caught and
// held (SignalHold): one that arrives then makes commit() refuse and runChild() stop its child;
// the temporaries are removed, and only then the signal takes its usual effect.

#include <sys/types.h>

#include <csignal>
#include <filesystem>
#include <map>
#include <optional>
#include <set>
#include <stdexcept>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace nvs {

// Catches SIGINT, SIGTERM, SIGHUP and SIGQUIT for its lifetime with a handler that only notes
// the signal (process-wide, so threads started earlier cannot be killed by them either). When
// it ends, the previous handlers are put back and a signal that arrived is raised again, so it
// takes its usual effect then. One at a time.
class SignalHold {
  public:
    SignalHold();
    ~SignalHold();
    SignalHold(const SignalHold&) = delete;
    SignalHold& operator=(const SignalHold&) = delete;
    // Whether a signal arrived while a SignalHold is in force.
    static bool pending() noexcept;

  private:
    struct sigaction old_[4]{};
};

class OutputFiles {
  public:
    OutputFiles() = default;
    ~OutputFiles();
    OutputFiles(const OutputFiles&) = delete;
    OutputFiles& operator=(const OutputFiles&) = delete;

    // An input no output may be (a file), or be, hold or lie inside (a folder). Outputs
    // declared before or after are checked against it. A path that does not exist is ignored.
    void addInput(const std::filesystem::path& path);
    // A file output given by `option` (named in errors, e.g. "--json").
    void addFile(const std::string& option, const std::filesystem::path& path);
    // A folder output: created new, or replacing a folder that holds the file `marker` (a
    // previous output of the same command). The temporary folder gets the marker as well.
    void addFolder(const std::string& option, const std::filesystem::path& path,
                   const std::string& marker);

    // Creates the declared output's temporary and returns its path (a new empty file, or a new
    // folder holding only the marker). Throws std::runtime_error naming the path on failure.
    std::filesystem::path stage(const std::filesystem::path& path);
    // stage() and write `text` to it; a write or close error throws.
    void writeText(const std::filesystem::path& path, std::string_view text);
    // stage() and let `write` fill the temporary by name. Whatever it throws becomes a
    // std::runtime_error naming `path`: a write that fails after the work is a run failure
    // (exit status 1), not a setup error.
    template <class Write>
    void writeWith(const std::filesystem::path& path, Write&& write) {
        const std::filesystem::path temp = stage(path);
        try {
            write(temp);
        } catch (const std::exception& e) {
            throw std::runtime_error(path.string() + ": write failed (" + e.what() + ")");
        }
    }
    // fsync every staged temporary and rename each into place. Throws std::runtime_error (the
    // temporaries removed, no final path touched) when one fails or a held signal is pending.
    void commit();
    // Removes every temporary not committed (the destructor calls it).
    void discard() noexcept;
    // Holds the signals (SignalHold) until this object is destroyed: its temporaries are
    // removed first, then a held signal is delivered.
    void holdSignals();

  private:
    struct Output {
        std::string option;
        std::filesystem::path path;  // as given, trailing '/' removed
        std::filesystem::path key;   // absolute, its folder resolved: for comparisons
        std::string marker;          // folders only
        bool folder = false;
        std::filesystem::path temp;  // empty until staged
        dev_t dev = 0;               // the temporary's identity, checked at commit
        ino_t ino = 0;
    };
    using FileId = std::pair<dev_t, ino_t>;
    Output& find(const std::filesystem::path& path);
    void checkAgainst(const Output& o, const FileId* id) const;
    void checkFolderTarget(const Output& o) const;
    void add(Output o);

    std::optional<SignalHold> hold_;
    std::vector<Output> outputs_;
    std::map<std::filesystem::path, std::size_t> outputIndex_;  // by key
    std::map<FileId, std::size_t> outputIds_;                   // existing file outputs
    std::vector<std::size_t> folderOutputs_;
    std::set<std::filesystem::path> probedFolders_;
    std::set<std::filesystem::path> inputKeys_;
    std::set<FileId> inputIds_;
    std::vector<std::filesystem::path> inputFolders_;
};

// Runs argv[0] with argv[1..] as a child process and waits for it; returns its exit status, or
// -1 when it could not be started or was killed. Under a SignalHold a signal that arrives while
// it runs stops the child (SIGTERM), which is waited for; returns -1 then (and commit() refuses).
int runChild(const std::vector<std::string>& argv);

}  // namespace nvs
