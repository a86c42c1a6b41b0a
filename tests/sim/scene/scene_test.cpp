// Scene and scenario loading, and the errors bad input gives.

#include "sim/scene/scene.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>

#include "sim/core/config.h"
#include "tests/sim/core/test_paths.h"

namespace nvs::scene {
namespace {

namespace fs = std::filesystem;

struct TempDir {
    fs::path dir;
    TempDir() {
        dir =
            fs::temp_directory_path() /
            ("nvs_scene_test_" + std::to_string(::testing::UnitTest::GetInstance()->random_seed()) +
             "_" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
        fs::create_directories(dir);
    }
    ~TempDir() { fs::remove_all(dir); }
    fs::path write(const std::string& name, const std::string& text) const {
        std::ofstream(dir / name) << text;
        return dir / name;
    }
};

const char* kQuadObj =
    "# a 1 m quad\n"
    "v 0 0 0\n"
    "v 1 0 0\n"
    "v 1 1 0\n"
    "v 0 1 0\n"
    "g face_grass\n"
    "f 1 2 3 4\n";

const char* kScene =
    "[[material]]\n"
    "name = \"grass\"\n"
    "reflectance = 0.35\n"
    "[layers]\n"
    "face_grass = \"grass\"\n"
    "[[object]]\n"
    "name = \"ground\"\n"
    "mesh = \"quad.obj\"\n";

std::string errorOf(const fs::path& p) {
    try {
        (void)loadScene(p);
    } catch (const SetupError& e) {
        return e.what();
    }
    return "";
}

TEST(Scene, LoadsMaterialsLayersAndTriangulates) {
    TempDir t;
    t.write("quad.obj", kQuadObj);
    const Scene s = loadScene(t.write("scene.toml", kScene));
    ASSERT_EQ(s.objects.size(), 1u);
    EXPECT_EQ(s.objects[0].mesh.triangleCount(), 2u);
    EXPECT_EQ(s.objects[0].mesh.materials[1], 0);
    EXPECT_DOUBLE_EQ(s.materials[0].reflectance[100], 0.35);
}

TEST(Scene, MissingMeshNamesTheSceneLine) {
    TempDir t;
    const std::string e = errorOf(t.write("scene.toml", kScene));
    EXPECT_NE(e.find("scene.toml:8"), std::string::npos) << e;
    EXPECT_NE(e.find("mesh file not found"), std::string::npos) << e;
}

TEST(Scene, UnknownMaterialNamesTheLine) {
    TempDir t;
    t.write("quad.obj", kQuadObj);
    std::string text = kScene;
    text.replace(text.find("face_grass = \"grass\""), 20, "face_grass = \"grsas\"");
    const std::string e = errorOf(t.write("scene.toml", text));
    EXPECT_NE(e.find("scene.toml:5"), std::string::npos) << e;
    EXPECT_NE(e.find("unknown material 'grsas'"), std::string::npos) << e;
}

TEST(Scene, UnmappedLayerNamesTheObjLine) {
    TempDir t;
    std::string obj = kQuadObj;
    obj.replace(obj.find("face_grass"), 10, "face_dirt_");
    t.write("quad.obj", obj);
    const std::string e = errorOf(t.write("scene.toml", kScene));
    EXPECT_NE(e.find("quad.obj:6"), std::string::npos) << e;
}

// A tracked object's truth class (docs/scene.md): given, or the object's name; one that the
// metadata's JSON could not hold as it is, or that does not fit its record, names its line.
TEST(Scene, TruthClassDefaultsToTheNameAndABadOneNamesItsLine) {
    TempDir t;
    t.write("quad.obj", kQuadObj);
    const std::string tracked = std::string(kScene) + "track_id = 3\n";
    const Scene named = loadScene(t.write("named.toml", tracked));
    EXPECT_EQ(named.objects[0].truthClass, "ground");
    const Scene given = loadScene(t.write("given.toml", tracked + "class = \"vehicle\"\n"));
    EXPECT_EQ(given.objects[0].truthClass, "vehicle");
    for (const char* bad : {"\"a \\\"quoted\\\" class\"", "\"sixteen-letters_\"", "\"\""}) {
        const std::string e = errorOf(t.write("bad.toml", tracked + "class = " + bad + "\n"));
        EXPECT_NE(e.find("bad.toml:10"), std::string::npos) << bad << ": " << e;
        EXPECT_NE(e.find("truth class"), std::string::npos) << e;
    }
    // An untracked object's name is not a class: any name goes.
    std::string untracked = kScene;
    untracked.replace(untracked.find("name = \"ground\""), 15, "name = \"a long object name\"");
    EXPECT_NO_THROW((void)loadScene(t.write("untracked.toml", untracked)));
}

TEST(Scene, NanVertexNamesTheObjLine) {
    TempDir t;
    std::string obj = kQuadObj;
    obj.replace(obj.find("v 1 1 0"), 7, "v 1 nan 0");
    t.write("quad.obj", obj);
    const std::string e = errorOf(t.write("scene.toml", kScene));
    EXPECT_NE(e.find("quad.obj:4"), std::string::npos) << e;
    EXPECT_NE(e.find("not a finite number"), std::string::npos) << e;
}

TEST(Scene, EmptySceneIsAnError) {
    TempDir t;
    const std::string e =
        errorOf(t.write("scene.toml", "[[material]]\nname = \"a\"\nreflectance = 0.2\n"));
    EXPECT_NE(e.find("empty scene"), std::string::npos) << e;
    EXPECT_NE(e.find("scene.toml"), std::string::npos) << e;
}

TEST(Scene, UnknownKeyIsAnError) {
    TempDir t;
    t.write("quad.obj", kQuadObj);
    const std::string e = errorOf(t.write("scene.toml", std::string(kScene) + "colour = 3\n"));
    EXPECT_NE(e.find("scene.toml:9"), std::string::npos) << e;
}

TEST(Scene, TrajectoryInterpolatesPoseAlongTheShorterArc) {
    Object o;
    o.trajectory = {{0.0, {0, 0, 0}, 350.0 * 3.141592653589793 / 180},
                    {2.0, {4, 2, 0}, 10.0 * 3.141592653589793 / 180}};
    Vec3 p;
    double yaw;
    o.poseAt(1.0, &p, &yaw);
    EXPECT_DOUBLE_EQ(p.x, 2.0);
    EXPECT_DOUBLE_EQ(p.y, 1.0);
    EXPECT_NEAR(std::remainder(yaw, 2 * 3.141592653589793), 0.0, 1e-12);
}

// A lamp riding on an object: placed by the object's pose (yaw turns +y toward +x, as the
// vertices); an unknown object or an aperture is an error naming the line.
TEST(Scene, AttachedLampIsPlacedByItsObjectsPose) {
    TempDir t;
    t.write("quad.obj", kQuadObj);
    const std::string lamp =
        "[[lamp]]\nname = \"head\"\nattach = \"ground\"\n"
        "position_m = [0.0, 2.0, 0.5]\naxis = [0.0, 1.0, 0.0]\n";
    const Scene s = loadScene(t.write("scene.toml", std::string(kScene) +
                                                        "position_m = [10.0, 0.0, 0.0]\n"
                                                        "yaw_deg = 90.0\n" +
                                                        lamp));
    ASSERT_EQ(s.lamps.size(), 1u);
    EXPECT_EQ(s.lamps[0].attachObject, 0);
    Vec3 p, a;
    s.lamps[0].placeAt(&s.objects[0], 0.0, &p, &a);
    EXPECT_NEAR(p.x, 12.0, 1e-12);  // the object's +y (2 m ahead) turned toward +x
    EXPECT_NEAR(p.y, 0.0, 1e-12);
    EXPECT_NEAR(p.z, 0.5, 1e-12);
    EXPECT_NEAR(a.x, 1.0, 1e-12);
    std::string bad = lamp;
    bad.replace(bad.find("\"ground\""), 8, "\"truck\"");
    std::string e = errorOf(t.write("bad.toml", std::string(kScene) + bad));
    EXPECT_NE(e.find("bad.toml:11"), std::string::npos) << e;
    EXPECT_NE(e.find("no [[object]] named 'truck'"), std::string::npos) << e;
    e = errorOf(t.write("ap.toml", std::string(kScene) + lamp + "aperture_diameter_m = 0.02\n"));
    EXPECT_NE(e.find("aperture"), std::string::npos) << e;
}

TEST(ConfigSkip, SkippedTablesAreNotUnknownButOthersStillAre) {
    const auto doc = ConfigDocument::parseString(
        "[platform]\nlat_deg = 1\n[runtime.sub]\nx = 2\n[mine]\nkey = 1\nstray = 2\n", "t.toml");
    const auto root = doc.root();
    root.skip("platform");
    root.skip("runtime");
    root.skip("absent");
    EXPECT_EQ(root.table("mine").get<int>("key", 0), 1);
    try {
        doc.finish();
        FAIL() << "stray key not reported";
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("t.toml:7"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace nvs::scene
