// The command line's rough edges (docs/contracts.md, "Command-line edges"): --camera and --set on
// run and render, a bare scenario name found in the data folders, a render refused by a camera
// it was not made for, a run without outputs, `nvstim list`. Each case runs nvstim on shipped
// scenarios at a small size (--set width/height), so every run takes well under a second.
#include <gtest/gtest.h>

#include <algorithm>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <map>
#include <regex>
#include <set>
#include <string>
#include <vector>

#include "sim/io/exr.h"
#include "tests/rt/cli/cli_run.h"

namespace nvs {
namespace {

namespace fs = std::filesystem;
using test::CliRun;
using test::nvstim;
using test::WorkDir;

const fs::path kSource = NVS_SOURCE_DIR;
const std::string kSmall = " --set width=96 --set height=64";

std::string readFile(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

std::string firstLine(const fs::path& p) {
    std::ifstream in(p, std::ios::binary);
    std::string line;
    std::getline(in, line);
    return line;
}

std::vector<std::string> lines(const std::string& text) {
    std::vector<std::string> out;
    std::size_t at = 0;
    while (at < text.size()) {
        const std::size_t nl = text.find('\n', at);
        out.push_back(text.substr(at, nl - at));
        at = nl == std::string::npos ? text.size() : nl + 1;
    }
    return out;
}

// ---- --camera and --set

TEST(CliEdges, RenderTakesCameraAndSetAndNamesTheCameraInItsHeader) {
    const WorkDir w;
    const fs::path out = w.path / "r.exr";
    const CliRun r = nvstim("render thesis-nolight --frame 0 --out " + out.string() +
                            " --camera gen2-s25-p20" + kSmall);
    ASSERT_EQ(r.status, 0) << r.err;
    const io::ExrImage exr = io::readExr(out);
    EXPECT_EQ(exr.image.width(), 96);  // the scenario says 768 x 494
    EXPECT_EQ(exr.image.height(), 64);
    EXPECT_EQ(exr.attribute("nvstim.camera"), "gen2-s25-p20");  // the scenario says pulnix
    EXPECT_EQ(io::readExr(w.path / "r.band.exr").image.width(), 96);
}

TEST(CliEdges, ARigRefusesCameraAndSetWithOneLine) {
    const WorkDir w;
    const fs::path out = w.path / "r.exr";
    for (const std::string& args :
         {"render rit-fusion --frame 0 --out " + out.string() + " --camera gen2-s25-p20",
          "render rit-fusion --frame 0 --out " + out.string() + " --set width=96",
          "run rit-fusion --clock sim --frames 1 --output y4m:" + out.string() +
              " --camera gen2-s25-p20"}) {
        const CliRun r = nvstim(args);
        test::expectOneLineRefusal(r, "--camera and --set are for a scenario with one [camera]");
        EXPECT_NE(r.err.find("[[channel]]"), std::string::npos) << r.err;
        EXPECT_FALSE(fs::exists(out)) << args;
    }
}

// run --set width/height gives the y4m header that size; --camera changes the frames (another
// tube), and naming the scenario's own preset changes nothing (the sim clock is bit-exact).
TEST(CliEdges, RunCameraAndSetChangeTheOutput) {
    const WorkDir w;
    const std::string run = "run thesis-nolight --clock sim --frames 1" + kSmall;
    const auto y4m = [&](const std::string& name, const std::string& extra) {
        const fs::path p = w.path / name;
        const CliRun r = nvstim(run + extra + " --output y4m:" + p.string());
        EXPECT_EQ(r.status, 0) << r.err;
        return p;
    };
    const fs::path plain = y4m("plain.y4m", "");
    const fs::path own = y4m("own.y4m", " --camera pulnix-ag5745ef3");
    const fs::path gen2 = y4m("gen2.y4m", " --camera gen2-s25-p20");
    EXPECT_NE(firstLine(plain).find(" W96 H64 "), std::string::npos) << firstLine(plain);
    EXPECT_NE(firstLine(gen2).find(" W96 H64 "), std::string::npos) << firstLine(gen2);
    EXPECT_EQ(readFile(own), readFile(plain));
    EXPECT_NE(readFile(gen2), readFile(plain));
    // A preset key: a lens opened two stops moves the frames too.
    const fs::path gain = y4m("gain.y4m", " --set f_number=2.8");
    EXPECT_NE(readFile(gain), readFile(plain));
}

// ---- Scenario names

// A bare name that is not in the working folder is the shipped scenario: the same frames as
// its path gives.
TEST(CliEdges, ABareScenarioNameIsFoundInTheDataFolders) {
    const WorkDir w;
    const std::string args = " --clock sim --frames 1" + kSmall + " --output y4m:";
    const CliRun byName = nvstim("run thesis-stlamp" + args + (w.path / "n.y4m").string(), w.path);
    ASSERT_EQ(byName.status, 0) << byName.err;
    const CliRun byPath = nvstim("run " + (kSource / "scenarios/thesis-stlamp").string() + args +
                                 (w.path / "p.y4m").string());
    ASSERT_EQ(byPath.status, 0) << byPath.err;
    EXPECT_EQ(readFile(w.path / "n.y4m"), readFile(w.path / "p.y4m"));
    // render and replay take the name as well (replay: a wrong one is refused the same way).
    const CliRun render =
        nvstim("render thesis-stlamp --frame 0 --out " + (w.path / "r.exr").string() + kSmall);
    EXPECT_EQ(render.status, 0) << render.err;
    const CliRun replay = nvstim("replay thesis-stlam --check");
    test::expectOneLineRefusal(replay, "nearest: thesis-stlamp");
}

// A name that matches nothing names the folder searched and the nearest names.
TEST(CliEdges, AnUnknownNameSaysWhereItLookedAndSuggests) {
    const WorkDir w;
    const CliRun r = nvstim("run thesis-stlam --clock sim --frames 1 --output y4m:" +
                            (w.path / "x.y4m").string());
    test::expectOneLineRefusal(r, "scenario 'thesis-stlam'");
    EXPECT_NE(r.err.find((kSource / "scenarios").string()), std::string::npos) << r.err;
    EXPECT_NE(r.err.find("nearest: thesis-stlamp"), std::string::npos) << r.err;
    const CliRun none =
        nvstim("run zzzzzzzzzz --clock sim --frames 1 --output y4m:" + (w.path / "x.y4m").string());
    test::expectOneLineRefusal(none, "nvstim list scenarios");
    EXPECT_EQ(none.err.find("nearest"), std::string::npos) << none.err;
}

// An installed tree: PREFIX/share/nvstim/config (here NVS_CONFIG_DIR) and its scenarios beside
// it; a scenario there is found by its name from any folder.
TEST(CliEdges, TheScenariosBesideTheConfigFolderAreSearched) {
    const WorkDir w;
    const fs::path share = w.path / "share" / "nvstim";
    fs::create_directories(share / "scenarios" / "tiny");
    fs::create_directory_symlink(kSource / "config", share / "config");
    std::ofstream(share / "scenarios" / "tiny" / "scenario.toml")
        << "[scenario]\nname = \"tiny\"\nwidth = 16\nheight = 16\n[[source]]\nkind = "
           "\"test_pattern\"\n";
    const std::string env = "env NVS_CONFIG_DIR=" + (share / "config").string() + " ";
    const CliRun r = nvstim(
        "run tiny --clock sim --frames 2 --output y4m:" + (w.path / "t.y4m").string(), w.path);
    test::expectOneLineRefusal(r, (kSource / "scenarios").string());  // not the installed tree
    // nvstim is run through `env` so the variable holds for it alone.
    const std::string cmd = "cd " + w.path.string() + " && " + env + NVSTIM_EXE +
                            " run tiny --clock sim --frames 2 --output y4m:t.y4m 2>&1";
    EXPECT_EQ(std::system(cmd.c_str()), 0) << cmd;
    EXPECT_NE(firstLine(w.path / "t.y4m").find(" W16 H16 "), std::string::npos);
}

// ---- Inputs for another camera

TEST(CliEdges, SensorRefusesARenderForAnotherCameraUnlessTold) {
    const WorkDir w;
    const fs::path exr = w.path / "r.exr";
    ASSERT_EQ(nvstim("render thesis-nolight --frame 0 --out " + exr.string() +
                     " --camera gen2-s25-p20" + kSmall)
                  .status,
              0);
    const std::string sensor = "sensor --in " + exr.string() + kSmall + " --out ";
    const fs::path out = w.path / "o.pgm";
    const CliRun other = nvstim(sensor + out.string() + " --camera pulnix-ag5745ef3");
    test::expectOneLineRefusal(other, "rendered for camera 'gen2-s25-p20'");
    EXPECT_NE(other.err.find("--camera 'pulnix-ag5745ef3'"), std::string::npos) << other.err;
    EXPECT_NE(other.err.find("--any-camera"), std::string::npos) << other.err;
    EXPECT_FALSE(fs::exists(out));
    // Told, it goes on; the same preset by name or by path is no other camera.
    EXPECT_EQ(nvstim(sensor + out.string() + " --camera pulnix-ag5745ef3 --any-camera").status, 0);
    EXPECT_EQ(nvstim(sensor + (w.path / "a.pgm").string() + " --camera gen2-s25-p20").status, 0);
    EXPECT_EQ(nvstim(sensor + (w.path / "b.pgm").string() + " --camera " +
                     (kSource / "config/cameras/gen2-s25-p20.toml").string())
                  .status,
              0);
}

// ---- Outputs and numbers

TEST(CliEdges, ARunWithoutOutputsIsAUsageError) {
    const WorkDir w;
    const CliRun r = nvstim("run thesis-nolight --clock sim --frames 1", w.path);
    test::expectOneLineRefusal(r, "no --output");
    EXPECT_NE(r.err.find("--output y4m:"), std::string::npos) << r.err;
    EXPECT_TRUE(fs::is_empty(w.path));
    // --stats alone is a run measured: it still runs.
    const CliRun stats = nvstim("run thesis-nolight --clock sim --frames 1" + kSmall + " --stats " +
                                (w.path / "s.json").string());
    EXPECT_EQ(stats.status, 0) << stats.err;
    EXPECT_TRUE(fs::exists(w.path / "s.json"));
}

TEST(CliEdges, FramesZeroIsOneLineNamingTheRange) {
    const WorkDir w;
    for (const auto& [args, range] : std::vector<std::pair<std::string, std::string>>{
             {"run thesis-nolight --frames 0 --output y4m:x.y4m", "[1, 100000000000]"},
             {"sensor --in x.exr --camera pulnix-ag5745ef3 --frames 0 --out o.pgm", "[1, 1000000]"},
             {"render thesis-nolight --frame -1 --out o.exr", "[0, 100000000000]"}}) {
        const CliRun r = nvstim(args, w.path);
        test::expectOneLineRefusal(r, range);
        // No number longer than 12 digits (it once printed a 309-digit one).
        EXPECT_FALSE(std::regex_search(r.err, std::regex("[0-9]{13}"))) << r.err;
    }
}

// ---- nvstim list

// The name (file stem) and `name` key of every preset file, and a scenario's [scenario]
// description, read here with a regular expression, not with nvstim's TOML reader.
std::string keyOf(const std::string& text, const std::string& key) {
    std::smatch m;
    const std::regex re("(^|\\n)" + key + " = \"([^\"]*)\"");
    return std::regex_search(text, m, re) ? m[2].str() : "";
}

TEST(CliEdges, ListPresetsNamesEveryPresetFileWithItsKind) {
    std::map<std::string, std::string> files;  // stem -> kind
    for (const auto& [folder, kind] :
         {std::pair{"cameras", "intensified"}, std::pair{"thermal_cameras", "thermal"}}) {
        for (const auto& e : fs::directory_iterator(kSource / "config" / folder)) {
            if (e.path().extension() != ".toml") continue;
            files[e.path().stem().string()] = kind;
            EXPECT_EQ(keyOf(readFile(e.path()), "name"), e.path().stem().string());
        }
    }
    const CliRun presets = nvstim("list presets");
    ASSERT_EQ(presets.status, 0) << presets.err;
    EXPECT_EQ(nvstim("list cameras").out, presets.out);
    std::map<std::string, std::string> listed;
    for (const std::string& line : lines(presets.out)) {
        std::smatch m;
        ASSERT_TRUE(std::regex_match(line, m, std::regex("(\\S+) +(\\S+) +(\\S.*)"))) << line;
        listed[m[1].str()] = m[2].str();
    }
    EXPECT_EQ(listed, files);
    // The opening comment's first clause: the PULNiX preset's, written out here.
    EXPECT_NE(presets.out.find("pulnix-ag5745ef3       intensified  PULNiX AG-5745EF-3 gated "
                               "intensified CCD, as used and modified in the thesis (RIT 1999)\n"),
              std::string::npos)
        << presets.out;
}

TEST(CliEdges, ListScenariosGivesEachDescriptionAsTextAndJson) {
    std::map<std::string, std::string> files;  // folder -> [scenario] description
    for (const auto& e : fs::directory_iterator(kSource / "scenarios")) {
        if (!fs::exists(e.path() / "scenario.toml")) continue;
        const std::string text = readFile(e.path() / "scenario.toml");
        files[e.path().filename().string()] = keyOf(text, "description");
        EXPECT_EQ(keyOf(text, "name"), e.path().filename().string());
    }
    ASSERT_GE(files.size(), 10u);
    const CliRun text = nvstim("list scenarios");
    ASSERT_EQ(text.status, 0) << text.err;
    const CliRun json = nvstim("list scenarios --json");
    ASSERT_EQ(json.status, 0) << json.err;
    std::map<std::string, std::string> fromText, fromJson;
    for (const std::string& line : lines(text.out)) {
        std::smatch m;
        ASSERT_TRUE(std::regex_match(line, m, std::regex("(\\S+) +(.*)"))) << line;
        fromText[m[1].str()] = m[2].str();
    }
    for (const std::string& line : lines(json.out)) {
        std::smatch m;
        ASSERT_TRUE(std::regex_match(
            line, m,
            std::regex(
                R"re(\{"name":"([^"]+)","group":"[^"]*","description":"((?:[^"\\]|\\.)*)",)re"
                R"re("path":"[^"]+"\})re")))
            << line;
        fromJson[m[1].str()] = m[2].str();
    }
    EXPECT_EQ(fromText, files);
    EXPECT_EQ(fromJson, files);  // no shipped description holds a quote or a backslash
}

}  // namespace
}  // namespace nvs
