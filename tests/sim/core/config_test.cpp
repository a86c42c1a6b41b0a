// Strict configuration: unknown keys, wrong types and syntax errors name file:line:column.
#include "sim/core/config.h"

#include <gtest/gtest.h>

#include <string>

#include "tests/sim/core/test_errors.h"

namespace nvs {
namespace {

constexpr const char* kCamera = R"(# a camera preset
name = "test"
f_numbr = 5.6
width = 768

[mcp]
gain_V = 4.4
)";

TEST(Config, MisspelledKeyNamesKeyLineAndSuggestion) {
    const ConfigDocument doc = ConfigDocument::parseString(kCamera, "camera.toml");
    const ConfigTable root = doc.root();
    EXPECT_EQ(root.get<std::string>("name", ""), "test");
    EXPECT_EQ(root.get<double>("f_number", 1.4), 1.4);  // absent: the default
    EXPECT_EQ(root.get<int>("width", 0), 768);
    EXPECT_EQ(root.table("mcp").get<double>("gain_V", 0.0), 4.4);
    const std::string msg = nvs::test::setupErrorOf([&] { doc.finish(); });
    EXPECT_EQ(msg, "camera.toml:3:1: unknown key 'f_numbr' (did you mean 'f_number'?)") << msg;
}

TEST(Config, UnusedKeysInNestedTablesAndArraysAreReported) {
    const ConfigDocument doc = ConfigDocument::parseString(R"(
[mcp]
gain_V = 4.4
gamma = 9

[[roi]]
name = "panel"
x = 1
wide = 3
)",
                                                           "s.toml");
    const ConfigTable root = doc.root();
    root.table("mcp").get<double>("gain_V", 0.0);
    for (const ConfigTable& roi : root.tableArray("roi")) {
        roi.get<std::string>("name", "");
        roi.get<int>("x", 0);
        roi.get<int>("w", 0);
    }
    const std::string msg = nvs::test::setupErrorOf([&] { doc.finish(); });
    EXPECT_NE(msg.find("s.toml:4:1: unknown key 'mcp.gamma'"), std::string::npos) << msg;
    EXPECT_NE(msg.find("1 more unknown key ('roi[0].wide' at line 9)"), std::string::npos) << msg;
}

TEST(Config, UnreadTableIsAnUnknownKey) {
    const ConfigDocument doc = ConfigDocument::parseString("a = 1\n[extra]\nb = 2\n", "t.toml");
    doc.root().get<int>("a", 0);
    EXPECT_EQ(nvs::test::setupErrorOf([&] { doc.finish(); }), "t.toml:2:2: unknown key 'extra'");
}

TEST(Config, WrongTypeNamesKeyAndPlace) {
    const ConfigDocument doc =
        ConfigDocument::parseString("[optics]\nf_number = \"fast\"\n", "c.toml");
    const std::string msg =
        nvs::test::setupErrorOf([&] { doc.root().table("optics").get<double>("f_number", 1.0); });
    EXPECT_EQ(msg, "c.toml:2:12: key 'optics.f_number': must be a number, found a string");
}

TEST(Config, IntegerAcceptedAsNumberButNotViceVersa) {
    const ConfigDocument doc = ConfigDocument::parseString("a = 3\nb = 2.5\n", "n.toml");
    EXPECT_EQ(doc.root().get<double>("a", 0.0), 3.0);
    EXPECT_NE(
        nvs::test::setupErrorOf([&] { doc.root().get<int>("b", 0); }).find("must be an integer"),
        std::string::npos);
}

TEST(Config, ArraysAreTypedElementwise) {
    const ConfigDocument doc =
        ConfigDocument::parseString("tau = [0.001, 2, 3e-3]\nbad = [1, \"x\"]\n", "a.toml");
    EXPECT_EQ(doc.root().get<std::vector<double>>("tau", {}),
              (std::vector<double>{0.001, 2.0, 3e-3}));
    EXPECT_NE(nvs::test::setupErrorOf([&] {
                  doc.root().get<std::vector<double>>("bad", {});
              }).find("a.toml:2:7: key 'bad': must be an array of a numbers"),
              std::string::npos);
}

TEST(Config, MissingRequiredKeyAndTable) {
    const ConfigDocument doc = ConfigDocument::parseString("[site]\nlat_deg = 43.2\n", "r.toml");
    const ConfigTable site = doc.root().table("site");
    EXPECT_EQ(nvs::test::setupErrorOf([&] { site.require<double>("lon_deg"); }),
              "r.toml:1:1: missing required key 'site.lon_deg' (a number)");
    EXPECT_EQ(nvs::test::setupErrorOf([&] { doc.root().table("camera"); }),
              "r.toml:1:1: missing required table [camera]");
}

TEST(Config, SyntaxErrorHasLineAndColumn) {
    const std::string msg = nvs::test::setupErrorOf(
        [] { ConfigDocument::parseString("a = 1\nb = = 2\n", "bad.toml"); });
    EXPECT_EQ(msg.rfind("bad.toml:2:", 0), 0u) << msg;
    EXPECT_NE(msg.find("TOML syntax"), std::string::npos);
}

TEST(Config, FailNamesTheValue) {
    const ConfigDocument doc = ConfigDocument::parseString("\n\nwidth = -5\n", "v.toml");
    const ConfigTable root = doc.root();
    const int w = root.get<int>("width", 640);
    const std::string msg = nvs::test::setupErrorOf([&] {
        if (w <= 0) root.fail("width", "must be positive, is " + std::to_string(w));
    });
    EXPECT_EQ(msg, "v.toml:3:9: key 'width': must be positive, is -5");
}

TEST(Config, CompleteFileFinishesCleanly) {
    const ConfigDocument doc = ConfigDocument::parseString(kCamera, "camera.toml");
    const ConfigTable root = doc.root();
    root.get<std::string>("name", "");
    root.get<double>("f_numbr", 0.0);
    root.get<int>("width", 0);
    root.table("mcp").get<double>("gain_V", 0.0);
    EXPECT_NO_THROW(doc.finish());
}

TEST(Config, MissingFileNamesThePath) {
    EXPECT_EQ(nvs::test::setupErrorOf([] { ConfigDocument::parseFile("/nonexistent/x.toml"); }),
              "/nonexistent/x.toml: cannot open configuration file: No such file or directory");
}

TEST(Config, EditDistance) {
    EXPECT_EQ(editDistance("f_number", "f_numbr"), 1u);
    EXPECT_EQ(editDistance("gain", "gian"), 2u);
    EXPECT_EQ(editDistance("", "abc"), 3u);
}

}  // namespace
}  // namespace nvs
