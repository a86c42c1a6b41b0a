// A thermal scenario's bad inputs, end to end through `nvstim run` (issue 30, docs/thermal.md):
// each is one line naming the file and line at fault, exit status 2, and no frame written.
//   - a scene material without a thermal material, or one whose thermal material has no layers;
//   - a gap in the weather series;
//   - an emissivity outside 0–1 in the materials file;
//   - a thermal preset without [thermal], and [thermal] beside an intensified preset;
//   - a heat-balance key of [thermal] out of range.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <string>

#include "tests/rt/cli/cli_run.h"

namespace nvs {
namespace {
namespace fs = std::filesystem;
using test::nvstim;
using test::WorkDir;

const fs::path kSource = NVS_SOURCE_DIR;

void write(const fs::path& p, const std::string& text) {
    std::ofstream(p) << text;
}

std::string readAll(const fs::path& p) {
    std::ifstream f(p);
    return std::string(std::istreambuf_iterator<char>(f), std::istreambuf_iterator<char>());
}

// The shipped thermal night with its scene, weather and materials copied into `dir`, each
// then edited by the case.
fs::path copyNight(const fs::path& dir) {
    fs::copy(kSource / "scenarios/rit", dir / "rit", fs::copy_options::recursive);
    fs::create_directories(dir / "night");
    std::string sc = readAll(kSource / "scenarios/thesis-nolight-lwir/scenario.toml");
    sc = std::regex_replace(sc, std::regex("weather = \"[^\"]*\""), "weather = \"weather.csv\"");
    sc = std::regex_replace(sc, std::regex("\\[thermal\\]\n"),
                            "[thermal]\nmaterials = \"materials.toml\"\n");
    write(dir / "night/scenario.toml", sc);
    fs::copy(kSource / "config/thermal/weather/rochester-1998-09-02.csv",
             dir / "night/weather.csv");
    fs::copy(kSource / "config/thermal/materials.toml", dir / "night/materials.toml");
    return dir / "night";
}

// Exit 2, one line on stderr, and it names `where` (file:line).
void expectOneLine(const test::CliRun& r, const std::string& where, const std::string& what) {
    test::expectOneLineRefusal(r, where);
    EXPECT_NE(r.err.find(what), std::string::npos) << r.err;
}

// One frame of the night in `night` under the sim clock, to PGM files in w/out.
test::CliRun runNight(const fs::path& night, const WorkDir& w) {
    return nvstim("run " + night.string() +
                  " --clock sim --frames 1 --output pgm:" + (w.path / "out").string());
}

TEST(ThermalInput, SceneMaterialWithoutThermalMaterialNamesItsLine) {
    WorkDir w;
    const fs::path night = copyNight(w.path);
    std::string scene = readAll(w.path / "rit/scene.toml");
    scene = std::regex_replace(scene, std::regex("thermal = \"grass\"\n"), "");
    write(w.path / "rit/scene.toml", scene);
    const auto r = runNight(night, w);
    expectOneLine(r, "scene.toml:", "'grass' has no `thermal` material");
    EXPECT_FALSE(fs::exists(w.path / "out/000000.pgm"));
}

TEST(ThermalInput, ThermalMaterialWithoutLayersNamesBothPlaces) {
    WorkDir w;
    const fs::path night = copyNight(w.path);
    std::string scene = readAll(w.path / "rit/scene.toml");
    scene =
        std::regex_replace(scene, std::regex("thermal = \"grass\""), "thermal = \"sky_backdrop\"");
    write(w.path / "rit/scene.toml", scene);
    const auto r = runNight(night, w);
    expectOneLine(r, "scene.toml:", "sky_backdrop");
}

TEST(ThermalInput, GapInTheWeatherNamesItsLine) {
    WorkDir w;
    const fs::path night = copyNight(w.path);
    // Drop 12 consecutive data rows from the middle of the series.
    std::ifstream in(night / "weather.csv");
    std::string line, out;
    int data = 0;
    while (std::getline(in, line)) {
        const bool isData = !line.empty() && line[0] >= '0' && line[0] <= '9';
        if (isData) ++data;
        if (isData && data > 20 && data <= 32) continue;
        out += line + "\n";
    }
    write(night / "weather.csv", out);
    const auto r = runNight(night, w);
    expectOneLine(r, "weather.csv:", "gap");
}

TEST(ThermalInput, EmissivityOutsideZeroToOneNamesItsLine) {
    WorkDir w;
    const fs::path night = copyNight(w.path);
    std::string m = readAll(night / "materials.toml");
    const auto at = m.find("[asphalt]");
    ASSERT_NE(at, std::string::npos);
    const auto e = m.find("emissivity = ", at);
    m.replace(e, m.find('\n', e) - e, "emissivity = 1.3");
    write(night / "materials.toml", m);
    const auto r = runNight(night, w);
    expectOneLine(r, "materials.toml:", "emissivity");
}

TEST(ThermalInput, ThermalTableAndPresetBelongTogether) {
    WorkDir w;
    const fs::path night = copyNight(w.path);
    std::string sc = readAll(night / "scenario.toml");
    write(night / "scenario.toml", std::regex_replace(sc, std::regex("preset = \"boson-640\""),
                                                      "preset = \"pulnix-ag5745ef3\""));
    auto r = runNight(night, w);
    expectOneLine(r, "scenario.toml:", "[thermal] needs a thermal camera preset");
    const auto cut = sc.find("[thermal]");
    const auto end = sc.find("[scene]");
    write(night / "scenario.toml", sc.substr(0, cut) + sc.substr(end));
    r = runNight(night, w);
    expectOneLine(r, "scenario.toml:", "needs a [thermal] table");
}

// The heat balance's keys of [thermal] (thermal::readHeatBalanceParams, shared with class-set
// files): a Linke turbidity outside 1–10 names its line.
TEST(ThermalInput, HeatBalanceKeyOutOfRangeNamesItsLine) {
    WorkDir w;
    const fs::path night = copyNight(w.path);
    std::string sc = readAll(night / "scenario.toml");
    write(night / "scenario.toml", std::regex_replace(sc, std::regex("\\[thermal\\]\n"),
                                                      "[thermal]\nlinke_turbidity = 20.0\n"));
    const auto r = runNight(night, w);
    expectOneLine(r, "scenario.toml:", "linke_turbidity");
}

}  // namespace
}  // namespace nvs
