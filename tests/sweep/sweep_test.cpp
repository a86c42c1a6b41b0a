// The parts of rt/sweep checked alone against hand-computed values: the JSON reader and
// writer, CSV quoting (RFC 4180), Slurm's array ranges, argument splitting, placeholders, the
// metrics of hand-made frames, and the seeded copy of a shipped scenario read back by the
// scenario loader.

#include <gtest/gtest.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <string>
#include <vector>

#include "rt/compose/scenario.h"
#include "rt/sweep/gather.h"
#include "rt/sweep/json.h"
#include "rt/sweep/metrics.h"
#include "rt/sweep/seeded_scenario.h"
#include "rt/sweep/slurm.h"
#include "rt/sweep/spec.h"
#include "sim/core/error.h"
#include "sim/core/image.h"
#include "sim/io/pnm.h"

namespace nvs::rt::sweep {
namespace {

namespace fs = std::filesystem;

fs::path tempDir(const std::string& name) {
    const fs::path d = fs::temp_directory_path() / ("nvs-sweep-test-" + name);
    fs::remove_all(d);
    fs::create_directories(d);
    return d;
}

TEST(SweepJson, ReadsWhatItWritesAndRejectsBrokenText) {
    const Json v = parseJson(R"( {"a": [1, 2.5, -3e2], "s": "x\"y\\n\u00e9", "t": true,
                                  "n": null, "o": {"k": "v"}} )",
                             "test");
    ASSERT_TRUE(v.isObject());
    EXPECT_EQ(v.find("a")->items().size(), 3u);
    EXPECT_DOUBLE_EQ(v.find("a")->items()[2].asNumber(), -300.0);
    EXPECT_EQ(v.stringOr("s", ""), "x\"y\\n\xc3\xa9");
    EXPECT_TRUE(v.find("t")->asBool());
    EXPECT_TRUE(v.find("n")->isNull());
    EXPECT_EQ(v.find("o")->stringOr("k", ""), "v");
    EXPECT_EQ(parseJson(v.dump(), "again").dump(), v.dump());
    EXPECT_THROW(parseJson("{\"a\":1,}", "t"), SetupError);
    EXPECT_THROW(parseJson("[1 2]", "t"), SetupError);
    EXPECT_THROW(parseJson("\"open", "t"), SetupError);
    EXPECT_THROW(parseJson("{} x", "t"), SetupError);
}

TEST(SweepJson, NumbersAreExactAndShortest) {
    EXPECT_EQ(jsonNumber(64.0), "64");
    EXPECT_EQ(jsonNumber(26.8), "26.8");
    EXPECT_EQ(jsonNumber(0.1 + 0.2), "0.30000000000000004");
    EXPECT_EQ(jsonNumber(NAN), "null");
    EXPECT_EQ(jsonQuote("a\tb\x01"), "\"a\\tb\\u0001\"");
}

TEST(SweepCsv, QuotesAsRfc4180) {
    EXPECT_EQ(csvField("plain"), "plain");
    EXPECT_EQ(csvField("a,b"), "\"a,b\"");
    EXPECT_EQ(csvField("say \"hi\""), "\"say \"\"hi\"\"\"");
    EXPECT_EQ(csvField("two\nlines"), "\"two\nlines\"");
}

TEST(SweepSlurm, ArrayRangesAndArguments) {
    EXPECT_EQ(arrayRanges({0, 1, 2, 3}), "0-3");
    EXPECT_EQ(arrayRanges({0, 1, 2, 3, 7, 9, 10, 11}), "0-3,7,9-11");
    EXPECT_EQ(arrayRanges({5}), "5");
    const std::vector<std::string> a = splitArgs(" -p short  --comment='a b' \"c d\" '' ");
    EXPECT_EQ(a, (std::vector<std::string>{"-p", "short", "--comment=a b", "c d", ""}));
    EXPECT_THROW(splitArgs("'open"), SetupError);
    const std::string s = sbatchScript("g", {0, 1, 2}, 4, "/bin/nvstim", "/o", "/w");
    EXPECT_NE(s.find("#SBATCH --array=0-2%4\n"), std::string::npos);
    EXPECT_NE(s.find("exec '/bin/nvstim' sweep --task \"$SLURM_ARRAY_TASK_ID\" --manifest "
                     "'/o/manifest.jsonl'"),
              std::string::npos);
}

TEST(SweepSpec, Placeholders) {
    const std::map<std::string, std::string> v = {{"a", "1"}, {"b.c", "x y"}};
    EXPECT_EQ(expandPlaceholders("{a}-{b.c}-{{a}}", v, "t"), "1-x y-{a}");
    EXPECT_THROW(expandPlaceholders("{z}", v, "t"), SetupError);
    EXPECT_THROW(expandPlaceholders("{a", v, "t"), SetupError);
    EXPECT_THROW(expandPlaceholders("a}", v, "t"), SetupError);
}

// Two 4×2 frames at 4 bits (top code 15), counts chosen so that every metric is known:
// 16 pixels: 0 ×4, 5 ×6, 10 ×4, 15 ×2. Mean 100/16 = 6.25; mean of squares
// (150 + 400 + 450)/16 = 62.5; variance 62.5 - 39.0625 = 23.4375; p99: count(≤ 10) = 14 < 15.84,
// so 15; at the top: 2/16.
TEST(SweepMetrics, OfHandMadeFrames) {
    const fs::path d = tempDir("metrics");
    const fs::path frames = d / "frames";
    fs::create_directories(frames);
    const std::uint16_t a[8] = {0, 0, 5, 5, 5, 10, 10, 15};
    const std::uint16_t b[8] = {0, 0, 5, 5, 5, 10, 10, 15};
    for (int f = 0; f < 2; ++f) {
        ImageU16 img(4, 2);
        for (int i = 0; i < 8; ++i)
            img(i % 4, i / 4) = (f == 0 ? a : b)[i];
        io::writePgm(frames / ("00000" + std::to_string(f) + ".pgm"), img.cview(), 15);
    }
    std::ofstream(d / "stats.json")
        << R"({"frames_emitted":2,"sink_errors":0,"frame_time":{"mean_s":0.5}})";
    const Json m = measureRun(frames, d / "stats.json");
    EXPECT_EQ(m.numberOr("frames", -1), 2);
    EXPECT_DOUBLE_EQ(m.numberOr("mean_counts", -1), 6.25);
    EXPECT_DOUBLE_EQ(m.numberOr("std_counts", -1), std::sqrt(23.4375));
    EXPECT_EQ(m.numberOr("p99_counts", -1), 15);
    EXPECT_EQ(m.numberOr("adc_top", -1), 15);
    EXPECT_DOUBLE_EQ(m.numberOr("adc_top_fraction", -1), 2.0 / 16.0);
    EXPECT_EQ(m.numberOr("frames_emitted", -1), 2);
    EXPECT_EQ(m.numberOr("frame_time_mean_s", -1), 0.5);
    // FNV-1a of the 16 samples as little-endian bytes, computed here.
    std::uint64_t h = 0xcbf29ce484222325ull;
    for (int f = 0; f < 2; ++f)
        for (const std::uint16_t v : a)
            for (const unsigned byte : {v & 0xffu, static_cast<unsigned>(v >> 8)}) {
                h ^= byte;
                h *= 0x100000001b3ull;
            }
    char hex[20];
    std::snprintf(hex, sizeof hex, "%016llx", static_cast<unsigned long long>(h));
    EXPECT_EQ(m.stringOr("frames_fnv", ""), hex);
    EXPECT_THROW(measureRun(d / "none", d / "stats.json"), SetupError);
}

// The seeded copy of a rendered scenario with a replayed telemetry log (airborne-pass: [scene]
// file and [telemetry] source relative to its folder) loads where the copy lies, with the seed.
TEST(SweepSeededScenario, LoadsFromElsewhereWithTheSeed) {
    const fs::path d = tempDir("seeded");
    const fs::path config = fs::path(NVS_SOURCE_DIR) / "config";
    const fs::path original = fs::path(NVS_SOURCE_DIR) / "scenarios" / "airborne-pass";
    writeSeededScenario(original, 12345, d / "scenario.toml");
    const Scenario a = loadScenario(original, config);
    const Scenario b = loadScenario(d / "scenario.toml", config);
    EXPECT_EQ(b.seed, 12345u);
    EXPECT_EQ(b.camera.seed, 12345u);
    EXPECT_NE(a.seed, 12345u);
    EXPECT_EQ(b.name, a.name);
    EXPECT_EQ(b.width, a.width);
    EXPECT_EQ(b.rate.num, a.rate.num);
    EXPECT_EQ(b.scene.sceneFile.lexically_normal(), a.scene.sceneFile.lexically_normal());
    EXPECT_EQ(b.telemetry, a.telemetry);
    EXPECT_EQ(b.events.size(), a.events.size());
}

// "replay:PATH" with PATH lexically normal (the copy writes it so, the loader keeps "dir/../").
std::optional<std::string> normalReplay(const std::optional<std::string>& spec) {
    if (!spec || spec->rfind("replay:", 0) != 0) return spec;
    return "replay:" + fs::path(spec->substr(7)).lexically_normal().string();
}

// Every shipped scenario's seeded copy loads from another folder and reads the same files
// (the paths rt/sweep/seeded_scenario.h makes absolute are all the relative ones there are).
TEST(SweepSeededScenario, EveryShippedScenarioLoadsFromElsewhere) {
    const fs::path d = tempDir("seeded-all");
    const fs::path config = fs::path(NVS_SOURCE_DIR) / "config";
    int n = 0;
    for (const auto& e : fs::directory_iterator(fs::path(NVS_SOURCE_DIR) / "scenarios")) {
        if (!fs::is_regular_file(e.path() / "scenario.toml")) continue;
        SCOPED_TRACE(e.path().string());
        const fs::path copy = d / (e.path().filename().string() + ".toml");
        writeSeededScenario(e.path(), 77, copy);
        const Scenario a = loadScenario(e.path(), config);
        const Scenario b = loadScenario(copy, config);
        EXPECT_EQ(b.seed, 77u);
        EXPECT_EQ(b.scene.sceneFile.lexically_normal(), a.scene.sceneFile.lexically_normal());
        EXPECT_EQ(normalReplay(b.telemetry), normalReplay(a.telemetry));
        EXPECT_EQ(b.scene.thermal.has_value(), a.scene.thermal.has_value());
        if (a.scene.thermal && b.scene.thermal) {
            EXPECT_EQ(b.scene.thermal->weatherFile.lexically_normal(),
                      a.scene.thermal->weatherFile.lexically_normal());
            EXPECT_EQ(b.scene.thermal->materialsFile.lexically_normal(),
                      a.scene.thermal->materialsFile.lexically_normal());
        }
        EXPECT_EQ(b.channels.size(), a.channels.size());
        ++n;
    }
    EXPECT_GE(n, 15);
}

}  // namespace
}  // namespace nvs::rt::sweep
