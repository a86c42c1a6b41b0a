#pragma once
// Running the nvstim executable from a test: its exit status, stdout and stderr apart, and a
// folder of the test's own (ctest runs the tests of one file in parallel processes).
#include <gtest/gtest.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <string>

namespace nvs::test {

struct CliRun {
    int status = -1;
    std::string out, err;
};

// BINARY_DIR/test-SUITE-NAME-PID<what>: this test's own path.
inline std::filesystem::path testPath(const std::string& what) {
    const auto* info = ::testing::UnitTest::GetInstance()->current_test_info();
    return std::filesystem::path(NVS_BINARY_DIR) /
           ("test-" + std::string(info->test_suite_name()) + "-" + std::string(info->name()) + "-" +
            std::to_string(::getpid()) + what);
}

// Runs `nvstim ARGS` (in `cwd` when given).
inline CliRun nvstim(const std::string& args, const std::filesystem::path& cwd = {}) {
    CliRun r;
    const std::filesystem::path errFile = testPath("-stderr.txt");
    const std::string cmd = (cwd.empty() ? "" : "cd " + cwd.string() + " && ") +
                            std::string(NVSTIM_EXE) + " " + args + " 2>" + errFile.string();
    FILE* p = popen(cmd.c_str(), "r");
    if (p == nullptr) return r;
    std::array<char, 4096> buf{};
    std::size_t n = 0;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0)
        r.out.append(buf.data(), n);
    const int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    {
        std::ifstream e(errFile);
        r.err.assign(std::istreambuf_iterator<char>(e), std::istreambuf_iterator<char>());
    }
    std::filesystem::remove(errFile);
    return r;
}

// A refused command line: exit status 2 and one line on stderr that names `what`.
inline void expectOneLineRefusal(const CliRun& r, const std::string& what) {
    EXPECT_EQ(r.status, 2) << r.err;
    EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
}

// The test's folder, empty at the start and removed at the end.
struct WorkDir {
    std::filesystem::path path = testPath("");
    WorkDir() {
        std::filesystem::remove_all(path);
        std::filesystem::create_directories(path);
    }
    ~WorkDir() { std::filesystem::remove_all(path); }
    WorkDir(const WorkDir&) = delete;
    WorkDir& operator=(const WorkDir&) = delete;
};

}  // namespace nvs::test
