// The output layer (sim/core/output_file.h) on its own: all outputs or none, temporaries that
// never reuse or follow what is there, a report folder replaced only when it carries the marker,
// nothing left behind on a failure or a held signal.
#include "sim/core/output_file.h"

#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <csignal>
#include <filesystem>
#include <fstream>
#include <string>
#include <thread>
#include <vector>

#include "sim/core/error.h"

namespace nvs {
namespace {

namespace fs = std::filesystem;

struct Dir {
    fs::path path = fs::path(::testing::TempDir()) /
                    ("nvs_output_" +
                     std::string(::testing::UnitTest::GetInstance()->current_test_info()->name()) +
                     "_" + std::to_string(::getpid()));
    Dir() {
        fs::remove_all(path);
        fs::create_directories(path);
    }
    ~Dir() { fs::remove_all(path); }
};

std::string read(const fs::path& p) {
    std::ifstream in(p);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::vector<std::string> names(const fs::path& dir) {
    std::vector<std::string> n;
    for (const auto& e : fs::directory_iterator(dir))
        n.push_back(e.path().filename().string());
    std::sort(n.begin(), n.end());
    return n;
}

TEST(OutputFiles, AllOutputsOrNone) {
    const Dir d;
    std::ofstream(d.path / "a.json") << "old a";
    {
        OutputFiles out;
        out.addFile("--a", d.path / "a.json");
        out.addFile("--b", d.path / "b.toml");
        out.writeText(d.path / "a.json", "new a");
        // The second output fails after the first was written: neither is put in place.
        EXPECT_THROW(out.writeWith(d.path / "b.toml",
                                   [](const fs::path&) { throw SetupError("disk full"); }),
                     std::runtime_error);
    }
    EXPECT_EQ(read(d.path / "a.json"), "old a");
    EXPECT_EQ(names(d.path), std::vector<std::string>{"a.json"});
    {
        OutputFiles out;
        out.addFile("--a", d.path / "a.json");
        out.addFile("--b", d.path / "b.toml");
        out.writeText(d.path / "a.json", "new a");
        out.writeText(d.path / "b.toml", "new b");
        out.commit();
    }
    EXPECT_EQ(read(d.path / "a.json"), "new a");
    EXPECT_EQ(read(d.path / "b.toml"), "new b");
    EXPECT_EQ(names(d.path), (std::vector<std::string>{"a.json", "b.toml"}));
}

TEST(OutputFiles, TemporariesNeverFollowOrReuseWhatIsThere) {
    const Dir d;
    std::ofstream(d.path / "victim") << "keep";
    for (const char* n : {"out.json.tmp", "out.json.part", "out.json.nvstim-tmp"})
        fs::create_symlink(d.path / "victim", d.path / n);
    fs::create_directories(d.path / "rep.tmp");
    std::ofstream(d.path / "rep.tmp" / "sentinel") << "keep";
    OutputFiles out;
    out.addFile("--json", d.path / "out.json");
    out.addFolder("--report", d.path / "rep", ".marker");
    const fs::path t = out.stage(d.path / "out.json");
    EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(t))) << t;
    EXPECT_EQ(fs::file_size(t), 0u);
    const fs::path r = out.stage(d.path / "rep");
    EXPECT_TRUE(fs::is_directory(fs::symlink_status(r)));
    EXPECT_EQ(names(r), std::vector<std::string>{".marker"});
    std::ofstream(t) << "json";
    std::ofstream(r / "report.md") << "report";
    out.commit();
    EXPECT_EQ(read(d.path / "victim"), "keep");
    EXPECT_EQ(read(d.path / "rep.tmp" / "sentinel"), "keep");
    EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(d.path / "out.json")));
    EXPECT_EQ(read(d.path / "out.json"), "json");
    EXPECT_EQ(read(d.path / "rep" / "report.md"), "report");
    EXPECT_EQ(names(d.path),
              (std::vector<std::string>{"out.json", "out.json.nvstim-tmp", "out.json.part",
                                        "out.json.tmp", "rep", "rep.tmp", "victim"}));
}

TEST(OutputFiles, AReportFolderIsReplacedOnlyWithItsMarker) {
    const Dir d;
    fs::create_directories(d.path / "rep");
    std::ofstream(d.path / "rep" / "mine.txt") << "keep";
    {
        OutputFiles out;
        try {
            out.addFolder("--report", d.path / "rep", ".marker");
            ADD_FAILURE() << "an unmarked folder was accepted";
        } catch (const SetupError& e) {
            EXPECT_NE(std::string(e.what()).find("--report " + (d.path / "rep").string()),
                      std::string::npos)
                << e.what();
        }
    }
    EXPECT_EQ(read(d.path / "rep" / "mine.txt"), "keep");
    std::ofstream(d.path / "rep" / ".marker") << "";
    {
        OutputFiles out;
        out.addFolder("--report", d.path / "rep/", ".marker");
        std::ofstream(out.stage(d.path / "rep") / "report.md") << "new";
        out.commit();
    }
    EXPECT_EQ(names(d.path / "rep"), (std::vector<std::string>{".marker", "report.md"}));
    EXPECT_EQ(names(d.path), std::vector<std::string>{"rep"});
}

// Counts SIGTERMs, standing in for the signal's usual effect (which would end the test).
volatile std::sig_atomic_t gTerms = 0;
extern "C" void countTerm(int) {
    gTerms = gTerms + 1;
}

struct CountTerms {
    struct sigaction old {};
    CountTerms() {
        gTerms = 0;
        struct sigaction sa {};
        sa.sa_handler = countTerm;
        sigemptyset(&sa.sa_mask);
        ::sigaction(SIGTERM, &sa, &old);
    }
    ~CountTerms() { ::sigaction(SIGTERM, &old, nullptr); }
};

TEST(OutputFiles, AHeldSignalLeavesNoOutputAndNoTemporary) {
    const Dir d;
    const CountTerms terms;
    std::ofstream(d.path / "a.json") << "old";
    {
        OutputFiles out;
        out.addFile("--a", d.path / "a.json");
        out.addFolder("--report", d.path / "rep", ".marker");
        out.holdSignals();
        out.writeText(d.path / "a.json", "new");
        (void)out.stage(d.path / "rep");
        ::raise(SIGTERM);  // held: noted, not delivered
        EXPECT_TRUE(SignalHold::pending());
        EXPECT_EQ(gTerms, 0);
        EXPECT_THROW(out.commit(), std::runtime_error);
        EXPECT_EQ(gTerms, 0);
    }
    // Delivered once the temporaries were gone.
    EXPECT_EQ(gTerms, 1);
    EXPECT_FALSE(SignalHold::pending());
    EXPECT_EQ(read(d.path / "a.json"), "old");
    EXPECT_EQ(names(d.path), std::vector<std::string>{"a.json"});
}

// A signal while a child runs (the report's plotter) stops the child at once; it is waited for.
TEST(OutputFiles, AHeldSignalStopsTheChildProcess) {
    const CountTerms terms;
    const auto t0 = std::chrono::steady_clock::now();
    int rc = 0;
    {
        const SignalHold hold;
        // Sent from another thread while the child sleeps: process-wide, caught by the hold.
        std::thread sender([] {
            std::this_thread::sleep_for(std::chrono::milliseconds(200));
            ::kill(::getpid(), SIGTERM);
        });
        rc = runChild({"sleep", "30"});
        sender.join();
        EXPECT_TRUE(SignalHold::pending());
    }
    EXPECT_EQ(rc, -1);
    EXPECT_LT(std::chrono::steady_clock::now() - t0, std::chrono::seconds(10));
    EXPECT_EQ(gTerms, 1);
    EXPECT_EQ(runChild({"true"}), 0);
    EXPECT_EQ(runChild({"false"}), 1);
}

TEST(OutputFiles, OutputsMustDifferFromEachOtherAndTheInputs) {
    const Dir d;
    fs::create_directories(d.path / "in");
    std::ofstream(d.path / "in" / "data.toml") << "x";
    std::ofstream(d.path / "input.exr") << "x";
    fs::create_hard_link(d.path / "input.exr", d.path / "hard.exr");
    OutputFiles out;
    out.addInput(d.path / "in");
    out.addInput(d.path / "input.exr");
    out.addFile("--a", d.path / "a.json");
    EXPECT_THROW(out.addFile("--b", d.path / "sub" / ".." / "a.json"), SetupError);
    EXPECT_THROW(out.addFile("--b", d.path / "in" / "data.toml"), SetupError);
    EXPECT_THROW(out.addFile("--b", d.path / "hard.exr"), SetupError);
    EXPECT_THROW(out.addFolder("--r", d.path, ".marker"), SetupError);
    EXPECT_THROW(out.addFolder("--r", d.path / "in", ".marker"), SetupError);
    EXPECT_EQ(names(d.path), (std::vector<std::string>{"hard.exr", "in", "input.exr"}));
}

}  // namespace
}  // namespace nvs
