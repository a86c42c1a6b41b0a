// The nvstim command line as a user meets it: help lists every subcommand of docs/design.md §7, bad
// usage exits 2 with one line, unbuilt subcommands exit non-zero saying so.
#include "rt/cli/cli.h"

#include <gtest/gtest.h>
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

#include "tests/rt/cli/cli_run.h"

namespace nvs {
namespace {

struct Result {
    int status = -1;
    std::string out;  // stdout and stderr together
};

Result runNvstim(const std::string& args) {
    const test::CliRun r = test::nvstim(args);
    return {r.status, r.out + r.err};
}

TEST(Cli, HelpListsEverySubcommand) {
    const Result r = runNvstim("--help");
    EXPECT_EQ(r.status, 0);
    for (const char* cmd :
         {"run", "ephem", "illum", "render", "sensor", "replay", "list", "diagnose", "bench"}) {
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
    // Each bad invocation: exit 2 and exactly one line of output, naming what was wrong.
    const auto oneLine = [](const Result& r) {
        return !r.out.empty() && r.out.find('\n') == r.out.size() - 1;
    };
    struct Case {
        const char* args;
        const char* named;
    };
    for (const Case& c : {Case{"", "subcommand"}, Case{"frobnicate", "frobnicate"},
                          Case{"ephem --lat 95 --lon 0 --utc 2000-01-01T00:00:00Z", "--lat"},
                          Case{"ephem --lat 43 --lon 0 --utc 2000-13-01T00:00", "--utc"},
                          Case{"ephem --lat 43 --lon 0 --utc 3000-01-01T00:00:00Z", "3000"},
                          Case{"run scenario.toml --clock sundial", "sundial"},
                          Case{"replay dir --check --bless", "--bless"}}) {
        const Result r = runNvstim(c.args);
        EXPECT_EQ(r.status, cli::kExitUsage) << c.args;
        EXPECT_TRUE(oneLine(r)) << c.args << "\n" << r.out;
        EXPECT_NE(r.out.find(c.named), std::string::npos) << c.args << "\n" << r.out;
    }
}

TEST(Cli, VersionPrintsName) {
    const Result r = runNvstim("--version");
    EXPECT_EQ(r.status, 0);
    EXPECT_EQ(r.out.rfind("nvstim ", 0), 0u) << r.out;
}

// Both tube generations through every command that takes a camera: illum (with the per-lux
// photoelectron yields), sensor (W/m2/sr input, which needs the response curve), render and run
// (a scenario on the RIT scene with each preset, at a small size).
TEST(Cli, GenIIAndGenIIIPresetsWorkInEveryCommand) {
    namespace fs = std::filesystem;
    const fs::path dir = fs::temp_directory_path() / ("nvs_cli_gen_" + std::to_string(::getpid()));
    fs::create_directories(dir);
    {  // a 16×8 PFM of 1e-5 W m⁻² sr⁻¹
        std::ofstream pfm(dir / "in.pfm", std::ios::binary);
        pfm << "Pf\n16 8\n-1.0\n";
        const float v = 1e-5f;
        for (int i = 0; i < 16 * 8; ++i)
            pfm.write(reinterpret_cast<const char*>(&v), sizeof v);
    }
    const fs::path rit = fs::path(NVS_SOURCE_DIR) / "scenarios" / "rit" / "scene.toml";
    for (const char* preset : {"pulnix-ag5745ef3", "gen2-s25-p20"}) {
        Result r = runNvstim(std::string("illum --lat 43.17 --lon -77.62 --height-m 218 --utc "
                                         "1998-09-02T01:00:00Z --camera ") +
                             preset);
        EXPECT_EQ(r.status, 0) << preset << ": " << r.out;
        EXPECT_NE(r.out.find("\"pe_per_lux_s_m2\""), std::string::npos) << r.out;
        r = runNvstim(std::string("sensor --camera ") + preset +
                      " --set width=16 --set height=8 --unit W/m2/sr --in " +
                      (dir / "in.pfm").string() + " --out " + (dir / "out.pgm").string());
        EXPECT_EQ(r.status, 0) << preset << ": " << r.out;
        std::ofstream(dir / "s.toml")
            << "[scenario]\nname = \"gen\"\nwidth = 64\nheight = 48\nduration_s = 0.1\n"
               "utc_start = \"1998-09-02T01:00:00Z\"\n[site]\nlat_deg = 43.16856\n"
               "lon_deg = -77.61583\nheight_m = 218.0\n[camera]\npreset = \""
            << preset << "\"\n[scene]\nfile = \"" << rit.string() << "\"\n";
        r = runNvstim("render " + (dir / "s.toml").string() + " --frame 0 --out " +
                      (dir / "r.exr").string());
        EXPECT_EQ(r.status, 0) << preset << ": " << r.out;
        r = runNvstim("run " + (dir / "s.toml").string() +
                      " --clock sim --frames 2 --output y4m:" + (dir / "o.y4m").string());
        EXPECT_EQ(r.status, 0) << preset << ": " << r.out;
    }
    fs::remove_all(dir);
}

// `illum --camera` prints the tube at a control voltage (docs/contracts.md, "illum"): at the
// AGC's 9 V the PULNiX tube's luminous gain is the thesis's typical 15 000 (Appendix A, Table
// 11-1) in cd m⁻² lx⁻¹, 15 000·π fL/fc; --gain-v without --camera is a usage error.
TEST(Cli, IllumCameraPrintsTheTubeGainAtAControlVoltage) {
    const std::string base =
        "illum --lat 43.17 --lon -77.62 --height-m 218 --utc 1998-09-02T01:00:00Z";
    Result r = runNvstim(base + " --camera pulnix-ag5745ef3 --gain-v 9");
    ASSERT_EQ(r.status, 0) << r.out;
    const std::size_t at = r.out.find("\"luminous_gain_fL_fc\":");
    ASSERT_NE(at, std::string::npos) << r.out;
    const double g = std::stod(r.out.substr(at + 22));
    EXPECT_NEAR(g, 15000.0 * 3.14159265358979, 0.01 * g) << r.out;
    for (const char* key : {"\"tube\":{\"gain_V\":9", "\"mcp_electron_gain\":",
                            "\"mcp_electrons_per_photoelectron\":", "\"qe_peak\":"})
        EXPECT_NE(r.out.find(key), std::string::npos) << key << " in " << r.out;
    r = runNvstim(base + " --gain-v 9");
    EXPECT_NE(r.status, 0) << r.out;
}

// `nvstim sensor` on a full disk: a non-zero exit, no truncated output renamed into place and
// no temporary left (before: the PNG's fclose went unchecked, a truncated file was renamed into
// place, and a failed write left `.tmp` files). A file-size limit stands in for the full disk.
TEST(Cli, SensorOnAFullDiskLeavesNoFileAndNoTemporary) {
    namespace fs = std::filesystem;
    const fs::path dir =
        fs::temp_directory_path() / ("nvs_cli_sensor_" + std::to_string(::getpid()));
    fs::remove_all(dir);
    fs::create_directories(dir);
    {
        // A uniform PFM of the preset's size (768 x 494), 1e-5 W m^-2 sr^-1.
        std::ofstream in(dir / "in.pfm", std::ios::binary);
        in << "Pf\n768 494\n-1.0\n";
        const std::vector<float> row(768, 1e-5f);
        for (int y = 0; y < 494; ++y)
            in.write(reinterpret_cast<const char*>(row.data()), 768 * sizeof(float));
    }
    for (const char* out : {"out.png", "out.pgm", "out.exr"}) {
        const std::string cmd = "sh -c 'ulimit -f 4; exec " + std::string(NVSTIM_EXE) +
                                " sensor --in " + (dir / "in.pfm").string() +
                                " --camera pulnix-ag5745ef3 --unit W/m2/sr --frames 1 --out " +
                                (dir / out).string() + "' 2>&1";
        FILE* p = popen(cmd.c_str(), "r");
        ASSERT_NE(p, nullptr);
        std::string text;
        std::array<char, 4096> buf{};
        std::size_t n = 0;
        while ((n = fread(buf.data(), 1, buf.size(), p)) > 0)
            text.append(buf.data(), n);
        const int st = pclose(p);
        EXPECT_TRUE(WIFEXITED(st) && WEXITSTATUS(st) != 0) << out << ": " << text;
        for (const auto& e : fs::directory_iterator(dir)) {
            EXPECT_EQ(e.path().filename(), "in.pfm") << out << " left " << e.path() << "; " << text;
        }
    }
    fs::remove_all(dir);
}

// nvstim bench --filter memcpy --json F: valid JSON (checked by Python's json module, an
// independent parser) with the contract's keys for each benchmark kept by the filter, the same
// object on stdout; a filter that keeps nothing is a setup error (exit 2, one line).
// Runs `nvstim bench --filter FILTER --json JSON > OUT` (stderr dropped); the command line when
// it did not exit 0, else empty.
std::string benchFails(const std::string& filter, const std::filesystem::path& json,
                       const std::filesystem::path& out) {
    const std::string cmd = std::string(NVSTIM_EXE) + " bench --filter " + filter + " --json " +
                            json.string() + " > " + out.string() + " 2>/dev/null";
    const int st = std::system(cmd.c_str());
    return WIFEXITED(st) && WEXITSTATUS(st) == 0 ? std::string() : cmd;
}

TEST(Cli, BenchWritesJsonWithTheContractKeys) {
    namespace fs = std::filesystem;
    const fs::path json =
        fs::temp_directory_path() / ("nvs_cli_bench_" + std::to_string(::getpid()) + ".json");
    const fs::path out = fs::path(json).replace_extension(".stdout");
    ASSERT_EQ(benchFails("memcpy", json, out), "");
    const std::string check =
        "python3 -c \"import json,sys\n"
        "d = json.load(open(sys.argv[1])); s = json.load(open(sys.argv[2]))\n"
        "assert d == s, 'stdout differs from --json'\n"
        "names = sorted(b['name'] for b in d['benchmarks'])\n"
        "assert names == ['memcpy_frame_f32', 'memcpy_frame_u16'], names\n"
        "for b in d['benchmarks']:\n"
        "    for k in "
        "('name','what','iterations','min_s','p50_s','p99_s','mean_s','target_s','meets_target'):\n"
        "        assert k in b, k\n"
        "    assert b['iterations'] > 0 and 0 < b['min_s'] <= b['p50_s'] <= b['p99_s'], b\n"
        "    assert b['min_s'] <= b['mean_s'], b\n"
        "assert d['end_to_end'] == [] and isinstance(d['ratios'], dict)\n"
        "assert d['machine']['cpus'] >= 1 and len(d['machine']['load_avg_start']) == 3\n"
        "\" " +
        json.string() + " " + out.string();
    EXPECT_EQ(std::system(check.c_str()), 0) << check;
    fs::remove(json);
    fs::remove(out);
    const Result none = runNvstim("bench --filter no_such_benchmark");
    EXPECT_EQ(none.status, cli::kExitUsage) << none.out;
    EXPECT_NE(none.out.find("no_such_benchmark"), std::string::npos) << none.out;
    EXPECT_EQ(std::count(none.out.begin(), none.out.end(), '\n'), 1) << none.out;
}

// nvstim bench --filter sensor_chain_air: the 1280×1024 airborne camera's chain runs on a frame
// of the scenario's own size rendered at the flight log's first pose (a chain made at the
// preset's 768×494 would refuse the frame: no photoelectrons, and no time).
TEST(Cli, BenchFliesTheSxgaChainOnItsOwnFrames) {
    namespace fs = std::filesystem;
    const fs::path json =
        fs::temp_directory_path() / ("nvs_cli_bench_air_" + std::to_string(::getpid()) + ".json");
    ASSERT_EQ(benchFails("sensor_chain_air", json, "/dev/null"), "");
    const std::string check =
        "python3 -c \"import json,sys\n"
        "d = json.load(open(sys.argv[1]))\n"
        "b = d['benchmarks']\n"
        "assert [x['name'] for x in b] == ['sensor_chain_air_sxga'], b\n"
        "assert b[0]['mean_pe_per_px'] > 0.05, b[0]\n"
        "assert b[0]['target_s'] is None and b[0]['iterations'] > 0, b[0]\n"
        "\" " +
        json.string();
    EXPECT_EQ(std::system(check.c_str()), 0) << check;
    fs::remove(json);
}

}  // namespace
}  // namespace nvs
