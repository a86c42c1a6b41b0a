// The nvstim command line as a user meets it: help lists every subcommand of DESIGN §7, bad
// usage exits 2 with one line, unbuilt subcommands exit non-zero saying so.
#include "rt/cli/cli.h"

#include <gtest/gtest.h>
#include <sys/wait.h>

#include <array>
#include <cstdio>
#include <string>

namespace nvs {
namespace {

struct Result {
    int status = -1;
    std::string out;  // stdout and stderr together
};

Result runNvstim(const std::string& args) {
    Result r;
    const std::string cmd = std::string(NVSTIM_EXE) + " " + args + " 2>&1";
    FILE* p = popen(cmd.c_str(), "r");
    if (p == nullptr) return r;
    std::array<char, 4096> buf{};
    std::size_t n = 0;
    while ((n = fread(buf.data(), 1, buf.size(), p)) > 0)
        r.out.append(buf.data(), n);
    const int st = pclose(p);
    r.status = WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    return r;
}

TEST(Cli, HelpListsEverySubcommand) {
    const Result r = runNvstim("--help");
    EXPECT_EQ(r.status, 0);
    for (const char* cmd :
         {"run", "ephem", "illum", "render", "sensor", "replay", "diagnose", "bench"}) {
        EXPECT_NE(r.out.find(std::string("  ") + cmd), std::string::npos) << cmd << "\n" << r.out;
    }
}

TEST(Cli, SubcommandHelpDocumentsContractOptions) {
    EXPECT_NE(runNvstim("ephem --help").out.find("--pressure-hpa"), std::string::npos);
    EXPECT_NE(runNvstim("ephem --help").out.find("--temperature-c"), std::string::npos);
    EXPECT_NE(runNvstim("illum --help").out.find("--visibility-km"), std::string::npos);
    const std::string runHelp = runNvstim("run --help").out;
    for (const char* opt : {"--output", "--clock", "--frames", "--telemetry"}) {
        EXPECT_NE(runHelp.find(opt), std::string::npos) << opt;
    }
    const std::string sensorHelp = runNvstim("sensor --help").out;
    for (const char* opt :
         {"--in", "--camera", "--set", "--frames", "--seed", "--out", "--unit", "--spectrum"}) {
        EXPECT_NE(sensorHelp.find(opt), std::string::npos) << opt;
    }
    EXPECT_NE(runNvstim("replay --help").out.find("--bless"), std::string::npos);
    EXPECT_NE(runNvstim("diagnose --help").out.find("--report"), std::string::npos);
}

TEST(Cli, BadUsageExitsTwoWithOneClearLine) {
    Result r = runNvstim("");
    EXPECT_EQ(r.status, cli::kExitUsage);
    r = runNvstim("frobnicate");
    EXPECT_EQ(r.status, cli::kExitUsage);
    r = runNvstim("ephem --lat 95 --lon 0 --utc 2000-01-01T00:00:00Z");
    EXPECT_EQ(r.status, cli::kExitUsage);
    EXPECT_NE(r.out.find("--lat"), std::string::npos) << r.out;
    r = runNvstim("run scenario.toml --clock sundial");
    EXPECT_EQ(r.status, cli::kExitUsage);
    EXPECT_NE(r.out.find("sundial"), std::string::npos) << r.out;
    r = runNvstim("replay dir --check --bless");
    EXPECT_EQ(r.status, cli::kExitUsage);
}

TEST(Cli, VersionPrintsName) {
    const Result r = runNvstim("--version");
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.out.rfind("nvstim ", 0), 0u) << r.out;
}

}  // namespace
}  // namespace nvs
