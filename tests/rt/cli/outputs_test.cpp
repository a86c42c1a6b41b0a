// Outputs that never destroy a user's data, inputs that cannot hang or wrap (issue 27,
// docs/reliability-inputs.md "Outputs"): each test makes the hostile situation (a folder with a
// sentinel file, the dataset itself, ".", a symbolic link where a temporary might go, a FIFO, a
// number past its range) and checks the exit status, the one line naming the path or option,
// the sentinel intact and no temporary left. Every refusal here happens before any work, so the
// tests are quick.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rt/cli/cli.h"
#include "tests/rt/cli/cli_run.h"

namespace nvs {
namespace {

namespace fs = std::filesystem;

using test::CliRun;
using test::nvstim;
using test::WorkDir;

std::string readFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

void writeFile(const fs::path& p, const std::string& text) {
    std::ofstream(p, std::ios::binary) << text;
}

// Every file under `dir` (recursively) with its content: a snapshot to compare after the run.
std::vector<std::pair<std::string, std::string>> snapshot(const fs::path& dir) {
    std::vector<std::pair<std::string, std::string>> s;
    std::vector<fs::path> todo = {dir};
    while (!todo.empty()) {
        const fs::path d = todo.back();
        todo.pop_back();
        for (const auto& e : fs::directory_iterator(d)) {
            const std::string name = e.path().lexically_relative(dir).string();
            const fs::file_status st = fs::symlink_status(e.path());
            if (fs::is_symlink(st)) {
                s.emplace_back(name, "-> " + fs::read_symlink(e.path()).string());
            } else if (fs::is_directory(st)) {
                s.emplace_back(name, "<folder>");
                todo.push_back(e.path());
            } else if (fs::is_regular_file(st)) {
                s.emplace_back(name, readFile(e.path()));
            } else {
                s.emplace_back(name, "<other>");
            }
        }
    }
    std::sort(s.begin(), s.end());
    return s;
}

// One line on stderr that names `named`, the status, and nothing on stdout.
void expectOneLine(const CliRun& r, int status, const std::string& named, const std::string& what) {
    EXPECT_EQ(r.status, status) << what << ": " << r.err;
    ASSERT_FALSE(r.err.empty()) << what;
    EXPECT_EQ(r.err.find('\n'), r.err.size() - 1) << what << ": " << r.err;
    EXPECT_NE(r.err.find(named), std::string::npos) << what << ": " << r.err;
    EXPECT_LT(r.err.size(), 400u) << what << ": " << r.err;
    EXPECT_TRUE(r.out.empty()) << what << ": " << r.out;
}

// A folder that looks like a dataset from the outside (diagnose refuses its outputs before it
// reads the dataset).
fs::path fakeDataset(const fs::path& dir) {
    fs::create_directories(dir / "ds" / "frames");
    writeFile(dir / "ds" / "dataset.toml", "[camera]\npreset = \"pulnix-ag5745ef3\"\n");
    writeFile(dir / "ds" / "frames" / "000000.pgm", "sentinel frame");
    return dir / "ds";
}

TEST(Outputs, DiagnoseNeverReplacesAFolderThatIsNotItsReport) {
    const WorkDir work;
    const fs::path& dir = work.path;
    const fs::path ds = fakeDataset(dir);
    fs::create_directories(dir / "mine");
    writeFile(dir / "mine" / "sentinel.txt", "keep me");
    struct Case {
        std::string arg, named, cwd;
    };
    for (const Case& c : {Case{(dir / "mine").string(), "mine", ""},        // an existing folder
                          Case{(dir / "mine").string() + "/", "mine", ""},  // with a slash
                          Case{ds.string(), ds.string(), ""},               // the dataset itself
                          Case{".", ".", dir.string()},                     // the current folder
                          Case{dir.string(), dir.string(), (dir / "mine").string()},  // holds it
                          Case{(ds / "frames").string(), "frames", ""}}) {  // inside the input
        const auto before = snapshot(dir);
        const CliRun r = nvstim("diagnose " + ds.string() + " --report " + c.arg, c.cwd);
        expectOneLine(r, cli::kExitUsage, c.named, "--report " + c.arg);
        EXPECT_NE(r.err.find("--report"), std::string::npos) << r.err;
        EXPECT_EQ(snapshot(dir), before) << "--report " << c.arg;
    }
}

TEST(Outputs, DiagnoseChecksEveryOutputBeforeAnyWork) {
    const WorkDir work;
    const fs::path& dir = work.path;
    const fs::path ds = fakeDataset(dir);
    fs::create_directories(dir / "folder");
    writeFile(dir / "folder" / "sentinel.txt", "keep me");
    ::mkfifo((dir / "fifo").c_str(), 0600);
    fs::create_symlink(dir / "loop", dir / "loop");
    const std::string a = (dir / "a.json").string();
    struct Case {
        std::string args, named;
    };
    for (const Case& c :
         {Case{"--json " + (dir / "folder").string(), "folder"},
          Case{"--json /proc/nvstim-no-such.json", "/proc/nvstim-no-such.json"},
          Case{"--json " + a + " --write-preset /proc/p.toml", "/proc/p.toml"},
          Case{"--json " + a + " --write-preset " + a, "--write-preset"},
          Case{"--json " + a + " --write-preset " + (dir / "." / "a.json").string(), "a.json"},
          Case{"--json -", "'-'"}, Case{"--json " + (dir / "fifo").string(), "FIFO"},
          Case{"--json " + (dir / "loop").string(), "loop"},
          Case{"--json " + (dir / "no-such" / "a.json").string(), "no-such"},
          Case{"--json " + (ds / "dataset.toml").string(), "dataset.toml"},
          Case{"--write-preset " + (dir / "folder" / "p.toml").string() + " --report " +
                   (dir / "folder").string(),
               "folder"}}) {
        const auto before = snapshot(dir);
        const CliRun r = nvstim("diagnose " + ds.string() + " " + c.args);
        expectOneLine(r, cli::kExitUsage, c.named, c.args);
        EXPECT_EQ(snapshot(dir), before) << c.args;
    }
}

// A 16x8 PFM of 1e-5 W m^-2 sr^-1 for the camera at --set width=16 --set height=8.
const char* kSensor = " --camera pulnix-ag5745ef3 --set width=16 --set height=8 --unit W/m2/sr";

void writeSmallPfm(const fs::path& p) {
    std::ofstream pfm(p, std::ios::binary);
    pfm << "Pf\n16 8\n-1.0\n";
    const float v = 1e-5f;
    for (int i = 0; i < 16 * 8; ++i)
        pfm.write(reinterpret_cast<const char*>(&v), sizeof v);
}

TEST(Outputs, SensorRefusesOutputsThatWouldReplaceData) {
    const WorkDir work;
    const fs::path& dir = work.path;
    writeSmallPfm(dir / "in.pfm");
    fs::create_directories(dir / "dir.pgm");
    writeFile(dir / "dir.pgm" / "sentinel.txt", "keep me");
    // An EXR input, written by nvstim itself.
    ASSERT_EQ(nvstim("sensor --in " + (dir / "in.pfm").string() + kSensor + " --out " +
                     (dir / "in.exr").string())
                  .status,
              0);
    struct Case {
        std::string in, out, named;
    };
    for (const Case& c :
         {Case{"in.pfm", (dir / "dir.pgm").string(), "dir.pgm"},
          Case{"in.exr", (dir / "in.exr").string(), "in.exr"}, Case{"in.pfm", "-", "--out"}}) {
        const auto before = snapshot(dir);
        const CliRun r =
            nvstim("sensor --in " + (dir / c.in).string() + kSensor + " --out " + c.out);
        expectOneLine(r, cli::kExitUsage, c.named, c.out);
        EXPECT_EQ(snapshot(dir), before) << c.out;
    }
}

// The temporary is a new file (O_EXCL): a symbolic link where the old fixed temporary name was
// is neither followed nor replaced, and the output is a regular file.
TEST(Outputs, SensorTemporaryNeverFollowsALink) {
    const WorkDir work;
    const fs::path& dir = work.path;
    writeSmallPfm(dir / "in.pfm");
    writeFile(dir / "victim.txt", "keep me");
    fs::create_symlink(dir / "victim.txt", dir / "out.pgm.tmp.pgm");
    fs::create_symlink(dir / "victim.txt", dir / "out.pgm.tmp");
    const CliRun r = nvstim("sensor --in " + (dir / "in.pfm").string() + kSensor + " --out " +
                            (dir / "out.pgm").string());
    ASSERT_EQ(r.status, 0) << r.err;
    EXPECT_EQ(readFile(dir / "victim.txt"), "keep me");
    EXPECT_TRUE(fs::is_regular_file(fs::symlink_status(dir / "out.pgm")));
    EXPECT_EQ(readFile(dir / "out.pgm").substr(0, 2), "P5");
    for (const auto& e : fs::directory_iterator(dir))
        EXPECT_EQ(e.path().string().find(".nvstim-"), std::string::npos) << e.path();
}

// A file-size limit of 0: the write fails (EFBIG), the command fails, nothing is left.
TEST(Outputs, SensorWriteErrorLeavesNothing) {
    const WorkDir work;
    const fs::path& dir = work.path;
    writeSmallPfm(dir / "in.pfm");
    const std::string cmd = "sh -c 'ulimit -f 0; exec " + std::string(NVSTIM_EXE) +
                            " sensor --in " + (dir / "in.pfm").string() + kSensor +
                            " --frames 3 --out " + (dir / "f{frame:03d}.pgm").string() +
                            "' >/dev/null 2>&1";
    const int st = std::system(cmd.c_str());
    EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) == cli::kExitFailure) << st;
    std::vector<std::string> names;
    for (const auto& e : fs::directory_iterator(dir))
        names.push_back(e.path().filename().string());
    EXPECT_EQ(names, std::vector<std::string>{"in.pfm"});
}

TEST(Outputs, NumbersAreRangeCheckedNeverWrapped) {
    const WorkDir work;
    const fs::path& dir = work.path;
    writeSmallPfm(dir / "in.pfm");
    const std::string sensor =
        "sensor --in " + (dir / "in.pfm").string() + kSensor + " --out " + (dir / "o.pgm").string();
    struct Case {
        std::string args, named;
    };
    for (const Case& c :
         {Case{sensor + " --seed -1", "--seed -1"},
          Case{sensor + " --seed 18446744073709551616", "--seed"},
          Case{sensor + " --seed 99999999999999999999999", "--seed"},
          Case{sensor + " --seed 1e3", "--seed 1e3"}, Case{sensor + " --frames 0", "--frames 0"},
          Case{sensor + " --frames 1000001", "--frames"},
          Case{"diagnose " + dir.string() + " --seed -1", "--seed -1"},
          Case{"render x --frame 100000000000000000 --out o.exr", "--frame"},
          Case{"render x --frame 9223372036854775808 --out o.exr", "--frame"},
          Case{"render x --frame -1 --out o.exr", "--frame"},
          Case{"run x --frames 0", "--frames 0"}}) {
        const CliRun r = nvstim(c.args);
        expectOneLine(r, cli::kExitUsage, c.named, c.args);
        EXPECT_FALSE(fs::exists(dir / "o.pgm")) << c.args;
    }
}

// A frame far in the scenario's future: bounded where the ephemeris and tables hold, never a
// crash (it was a SIGSEGV in the sky lookup).
TEST(Outputs, RenderFrameBeyondTheTimeLimitIsRefused) {
    const WorkDir work;
    const fs::path& dir = work.path;
    const fs::path rit = fs::path(NVS_SOURCE_DIR) / "scenarios" / "rit" / "scene.toml";
    writeFile(dir / "s.toml",
              "[scenario]\nname = \"far\"\nwidth = 64\nheight = 48\nduration_s = 0.1\n"
              "utc_start = \"1998-09-02T01:00:00Z\"\n[site]\nlat_deg = 43.16856\n"
              "lon_deg = -77.61583\nheight_m = 218.0\n[camera]\npreset = \"pulnix-ag5745ef3\"\n"
              "[scene]\nfile = \"" +
                  rit.string() + "\"\n");
    const CliRun r = nvstim("render " + (dir / "s.toml").string() + " --frame 100000000000 --out " +
                            (dir / "r.exr").string());
    expectOneLine(r, cli::kExitUsage, "--frame 100000000000", "far frame");
    EXPECT_FALSE(fs::exists(dir / "r.exr"));
    // An existing folder where the band file would go: refused before the render.
    fs::create_directories(dir / "r.band.exr");
    const CliRun b = nvstim("render " + (dir / "s.toml").string() + " --frame 0 --out " +
                            (dir / "r.exr").string());
    expectOneLine(b, cli::kExitUsage, "r.band.exr", "band folder");
    EXPECT_FALSE(fs::exists(dir / "r.exr"));
}

// bench --json into a folder: refused before the benchmarks run.
TEST(Outputs, BenchJsonCheckedBeforeTheBenchmarks) {
    const WorkDir work;
    fs::create_directories(work.path / "folder");
    const CliRun r = nvstim("bench --filter memcpy --json " + (work.path / "folder").string());
    expectOneLine(r, cli::kExitUsage, "--json " + (work.path / "folder").string(), "bench");
    EXPECT_TRUE(fs::is_empty(work.path / "folder"));
}

TEST(Outputs, ReplayBlessOfANonScenarioCreatesNothing) {
    const WorkDir work;
    const fs::path& dir = work.path;
    fs::create_directories(dir / "empty");
    for (const fs::path& p : {dir / "empty", dir / "no-such"}) {
        const CliRun r = nvstim("replay " + p.string() + " --bless");
        expectOneLine(r, cli::kExitUsage, p.string(), p.string());
        EXPECT_FALSE(fs::exists(p / "expected")) << p;
    }
    EXPECT_FALSE(fs::exists(dir / "no-such"));
}

// A rig's outputs each name a channel; a single camera's run has none to name. One line each,
// before any frame (docs/contracts.md, "Output specs").
TEST(Outputs, ARigsOutputsNameTheirChannel) {
    const WorkDir work;
    const std::string rig = std::string(NVS_SOURCE_DIR) + "/scenarios/rit-fusion";
    const std::string y4m = (work.path / "x.y4m").string();
    struct Case {
        std::string args, says;
    };
    for (const Case& c :
         {Case{rig + " --output y4m:" + y4m, "name the channel with ?channel=NAME (ii, lwir)"},
          Case{rig + " --output 'y4m:" + y4m + "?channel=uv'", "no channel 'uv' (ii, lwir)"},
          Case{std::string(NVS_SOURCE_DIR) + "/scenarios/thesis-nolight --output 'y4m:" + y4m +
                   "?channel=ii'",
               "channel= needs a rig"}}) {
        const CliRun r = nvstim("run " + c.args + " --clock sim --frames 1");
        test::expectOneLineRefusal(r, c.says);
        EXPECT_FALSE(fs::exists(y4m)) << c.args;
    }
}

// A y4m stream says its pixels' shape: the PULNiX TM-745E's CCD has 11.0 × 13.0 µm cells
// (config/cameras/pulnix-ag5745ef3.toml, its Table 11-2), so a player must draw them 11:13
// (A11:13); the thermal core's 12 µm cells are square. At another image size the sensor's field
// of view is kept.
TEST(Outputs, Y4mHeaderGivesThePixelsAspect) {
    const WorkDir work;
    const std::string y4m = (work.path / "a.y4m").string();
    const std::string src = NVS_SOURCE_DIR;
    struct Case {
        std::string scenario, extra, aspect;
    };
    for (const Case& c : {Case{"/scenarios/thesis-stlamp", "", " A11:13 "},
                          Case{"/scenarios/thesis-nolight-lwir", "", " A1:1 "}}) {
        const CliRun r =
            nvstim("run " + src + c.scenario + " --clock sim --frames 1 --output y4m:" + y4m);
        ASSERT_EQ(r.status, 0) << r.err;
        std::ifstream f(y4m);
        std::string header;
        std::getline(f, header);
        EXPECT_NE(header.find(c.aspect), std::string::npos) << c.scenario << ": " << header;
    }
}

}  // namespace
}  // namespace nvs
