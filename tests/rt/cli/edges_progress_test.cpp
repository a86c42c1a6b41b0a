// The command line's rough edges, continued: progress lines with the total and the time left,
// a plain replay that leaves nothing in the temporary folder, and the README's default night
// checked against `nvstim ephem` so that it cannot drift from the scenario again.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cmath>
#include <cstdlib>
#include <ctime>
#include <filesystem>
#include <fstream>
#include <regex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include "tests/rt/cli/cli_run.h"

namespace nvs {
namespace {

namespace fs = std::filesystem;
using test::CliRun;
using test::nvstim;
using test::WorkDir;

const fs::path kSource = NVS_SOURCE_DIR;

std::string readFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

// Starts `sh -c CMD` with stderr to `err`, waits (up to 60 s) for a line matching `re` there,
// then sends SIGINT and waits for it. Returns the matching line ("" if none came).
std::string firstLineMatching(const std::string& cmd, const fs::path& err, const std::regex& re) {
    const pid_t pid = ::fork();
    if (pid == 0) {
        ::setpgid(0, 0);
        const std::string full = "exec " + cmd + " 2>" + err.string() + " >/dev/null";
        ::execl("/bin/sh", "sh", "-c", full.c_str(), static_cast<char*>(nullptr));
        ::_exit(127);
    }
    std::string found;
    const auto until = std::chrono::steady_clock::now() + std::chrono::seconds(60);
    while (found.empty() && std::chrono::steady_clock::now() < until) {
        std::this_thread::sleep_for(std::chrono::milliseconds(100));
        std::ifstream in(err);
        for (std::string line; std::getline(in, line);) {
            if (std::regex_search(line, re)) {
                found = line;
                break;
            }
        }
        int st = 0;
        if (::waitpid(pid, &st, WNOHANG) == pid) return found;  // ended by itself
    }
    ::kill(-pid, SIGINT);
    int st = 0;
    ::waitpid(pid, &st, 0);
    return found;
}

// ---- Progress

// A sim-clock run long enough for a status line: frame N/TOTAL, the rate, and the time left,
// which is what is left at that rate.
TEST(CliEdgesProgress, RunStatusGivesTheTotalAndTheTimeLeft) {
    const WorkDir w;
    std::ofstream(w.path / "s.toml") << "[scenario]\nname = \"long\"\nwidth = 64\nheight = "
                                        "48\n[[source]]\nkind = \"test_pattern\"\n";
    const std::regex line(R"(^nvstim run: frame (\d+)/(\d+)  ([0-9.]+) fps  (\d+) s left  misses)");
    const std::string got =
        firstLineMatching(std::string(NVSTIM_EXE) + " run " + (w.path / "s.toml").string() +
                              " --clock sim --frames 100000000000 --output y4m:/dev/null",
                          w.path / "err", line);
    ASSERT_FALSE(got.empty()) << readFile(w.path / "err");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(got, m, line));
    const double n = std::stod(m[1].str()), total = std::stod(m[2].str());
    const double fps = std::stod(m[3].str()), left_s = std::stod(m[4].str());
    EXPECT_EQ(total, 1e11);
    ASSERT_GT(fps, 0.0) << got;
    // (TOTAL − N) / rate, the rate printed with two decimals: within 1 % and a second.
    const double expected_s = (total - n) / fps;
    EXPECT_NEAR(left_s, expected_s, 0.01 * expected_s + 1.0) << got;
}

// A run of unknown length says no total and no time left.
TEST(CliEdgesProgress, RunStatusWithoutALengthHasNoTotal) {
    const WorkDir w;
    std::ofstream(w.path / "s.toml") << "[scenario]\nname = \"open\"\nwidth = 64\nheight = "
                                        "48\n[[source]]\nkind = \"test_pattern\"\n";
    const std::string got =
        firstLineMatching(std::string(NVSTIM_EXE) + " run " + (w.path / "s.toml").string() +
                              " --clock wall --output y4m:/dev/null",
                          w.path / "err", std::regex("^nvstim run: frame"));
    ASSERT_FALSE(got.empty()) << readFile(w.path / "err");
    EXPECT_TRUE(
        std::regex_search(got, std::regex(R"(^nvstim run: frame \d+  [0-9.]+ fps  misses)")))
        << got;
}

TEST(CliEdgesProgress, SensorProgressGivesTheTotalAndTheTimeLeft) {
    const WorkDir w;
    // A flat 32 × 24 input in pe/s/m2/sr (PFM, bottom-up rows; all equal).
    {
        std::ofstream f(w.path / "in.pfm", std::ios::binary);
        f << "Pf\n32 24\n-1.0\n";
        const float v = 1e9f;
        for (int i = 0; i < 32 * 24; ++i)
            f.write(reinterpret_cast<const char*>(&v), sizeof v);
    }
    const std::regex line(R"(^nvstim sensor: frame (\d+)/(\d+)  ([0-9.]+) fps  (\d+) s left$)");
    const std::string got = firstLineMatching(
        std::string(NVSTIM_EXE) + " sensor --in " + (w.path / "in.pfm").string() +
            " --camera pulnix-ag5745ef3 --set width=32 --set height=24 --frames 1000000 --out " +
            (w.path / "o.pgm").string(),
        w.path / "err", line);
    ASSERT_FALSE(got.empty()) << readFile(w.path / "err");
    std::smatch m;
    ASSERT_TRUE(std::regex_search(got, m, line));
    const double n = std::stod(m[1].str()), fps = std::stod(m[3].str());
    EXPECT_EQ(m[2].str(), "1000000");
    ASSERT_GT(fps, 0.0);
    const double expected_s = (1e6 - n) / fps;
    EXPECT_NEAR(std::stod(m[4].str()), expected_s, 0.01 * expected_s + 1.0) << got;
    EXPECT_FALSE(fs::exists(w.path / "o.pgm"));  // interrupted: nothing written
}

// ---- Replay

// A plain replay runs in a private folder under $TMPDIR and removes it, whether the run
// succeeded or failed; --out DIR keeps the frames there.
TEST(CliEdgesProgress, PlainReplayLeavesNothingInTheTemporaryFolder) {
    const WorkDir w;
    const fs::path tmp = w.path / "tmp";
    fs::create_directories(tmp);
    fs::create_directories(w.path / "sc");
    std::ofstream(w.path / "sc" / "scenario.toml")
        << "[scenario]\nname = \"sc\"\nwidth = 32\nheight = 24\nframe_rate_hz = 10\n"
           "duration_s = 0.5\n[[source]]\nkind = \"test_pattern\"\n";
    const std::string env = "env TMPDIR=" + tmp.string() + " " + NVSTIM_EXE + " replay ";
    const auto sh = [](const std::string& cmd, std::string* out) {
        FILE* p = ::popen((cmd + " 2>&1").c_str(), "r");
        char buf[512];
        while (p != nullptr && std::fgets(buf, sizeof buf, p) != nullptr)
            *out += buf;
        const int st = p == nullptr ? -1 : ::pclose(p);
        return WIFEXITED(st) ? WEXITSTATUS(st) : -1;
    };
    std::string out;
    ASSERT_EQ(sh(env + (w.path / "sc").string(), &out), 0) << out;
    EXPECT_NE(out.find("5 frames replayed, none kept"), std::string::npos) << out;
    EXPECT_TRUE(fs::is_empty(tmp)) << fs::directory_iterator(tmp)->path();
    // A replay whose run fails: refused, and still nothing left behind.
    std::ofstream(w.path / "sc" / "scenario.toml", std::ios::app) << "bogus_key = 1\n";
    out.clear();
    EXPECT_EQ(sh(env + (w.path / "sc").string(), &out), 2) << out;
    EXPECT_TRUE(fs::is_empty(tmp));
    // --out keeps them: five frames and the metadata.
    std::ofstream(w.path / "sc" / "scenario.toml")
        << "[scenario]\nname = \"sc\"\nwidth = 32\nheight = 24\nframe_rate_hz = 10\n"
           "duration_s = 0.5\n[[source]]\nkind = \"test_pattern\"\n";
    out.clear();
    ASSERT_EQ(sh(env + (w.path / "sc").string() + " --out " + (w.path / "kept").string(), &out), 0)
        << out;
    int frames = 0;
    for (const auto& e : fs::directory_iterator(w.path / "kept" / "frames"))
        frames += e.path().extension() == ".pgm" ? 1 : 0;
    EXPECT_EQ(frames, 5);
    EXPECT_TRUE(fs::exists(w.path / "kept" / "meta.jsonl"));
    EXPECT_TRUE(fs::is_empty(tmp));
    // A folder that holds something is not mixed into.
    out.clear();
    EXPECT_EQ(sh(env + (w.path / "sc").string() + " --out " + (w.path / "kept").string(), &out), 2)
        << out;
}

// ---- The README's default night

// The night README.md and docs/scenarios.md describe for `make run` (its SCENARIO default in
// the Makefile): the local date and time (EDT = UTC − 4 h) must be the scenario's utc_start and
// the Moon's lit fraction and altitude what `nvstim ephem` gives for its site then.
TEST(CliEdgesProgress, TheReadmesDefaultNightIsTheScenariosAndEphemsOwn) {
    std::smatch m;
    const std::string makefile = readFile(kSource / "Makefile");
    ASSERT_TRUE(std::regex_search(makefile, m, std::regex(R"(\nSCENARIO \?= scenarios/(\S+))")));
    const std::string name = m[1].str();
    const std::string scenario = readFile(kSource / "scenarios" / name / "scenario.toml");
    const auto number = [&](const std::string& key) {
        std::smatch k;
        EXPECT_TRUE(std::regex_search(scenario, k, std::regex("\\n" + key + " = ([-0-9.]+)")))
            << key;
        return k[1].str();
    };
    ASSERT_TRUE(std::regex_search(scenario, m, std::regex(R"re(utc_start = "([^"]+)")re")));
    const std::string utc = m[1].str();
    const CliRun ephem = nvstim("ephem --lat " + number("lat_deg") + " --lon " + number("lon_deg") +
                                " --height-m " + number("height_m") + " --utc " + utc);
    ASSERT_EQ(ephem.status, 0) << ephem.err;
    ASSERT_TRUE(std::regex_search(
        ephem.out, m,
        std::regex(R"("moon":\{"alt_deg":([-0-9.]+).*"illuminated_fraction":([0-9.]+))")));
    const long alt_deg = std::lround(std::stod(m[1].str()));
    const long lit_pct = std::lround(100.0 * std::stod(m[2].str()));
    // The stated local time, back to UTC by hand.
    const auto utcOf = [](int y, int mo, int d, int h, int mi) {
        std::tm t{};
        t.tm_year = y - 1900;
        t.tm_mon = mo - 1;
        t.tm_mday = d;
        t.tm_hour = h + 4;  // EDT
        t.tm_min = mi;
        const std::time_t s = ::timegm(&t);
        char b[32];
        std::strftime(b, sizeof b, "%Y-%m-%dT%H:%M:%SZ", std::gmtime(&s));
        return std::string(b);
    };
    for (const auto& [doc, pattern] : std::vector<std::pair<std::string, std::string>>{
             {"README.md",
              R"(\((\d{4})-(\d\d)-(\d\d) (\d\d):(\d\d) EDT,\s+Moon (\d+) % lit at (\d+)°\))"},
             {"docs/scenarios.md",
              "`" + name +
                  R"(` \| \w+ \| RIT roof (\d{4})-(\d\d)-(\d\d) (\d\d):(\d\d) EDT: )"
                  R"(Moon (\d+) % lit at (\d+)°)"}}) {
        const std::string text = readFile(kSource / doc);
        ASSERT_TRUE(std::regex_search(text, m, std::regex(pattern))) << doc;
        EXPECT_EQ(utcOf(std::stoi(m[1].str()), std::stoi(m[2].str()), std::stoi(m[3].str()),
                        std::stoi(m[4].str()), std::stoi(m[5].str())),
                  utc)
            << doc << ": " << m[0];
        EXPECT_EQ(std::stol(m[6].str()), lit_pct)
            << doc << ": " << m[0] << "; ephem: " << ephem.out;
        EXPECT_EQ(std::stol(m[7].str()), alt_deg)
            << doc << ": " << m[0] << "; ephem: " << ephem.out;
    }
}

}  // namespace
}  // namespace nvs
