// OBJ meshes as inputs (docs/reliability-inputs.md): a mesh path to /dev/zero (read without
// end before) or a FIFO (a read that blocked forever) is an error naming the path; faces that
// refer to vertices the file does not have are errors before the scene is built.
#include <gtest/gtest.h>
#include <sys/stat.h>
#include <unistd.h>

#include <string>

#include "sim/core/error.h"
#include "sim/scene/scene.h"

namespace nvs::scene {
namespace {

std::string meshError(const std::string& path) {
    try {
        loadObjMesh(path, {}, 0, FileLoc{"scene.toml", 3});
    } catch (const SetupError& e) {
        return e.what();
    }
    return "<no error>";
}

TEST(ObjInput, DevZeroAndFifoAreRefused) {
    EXPECT_NE(meshError("/dev/zero").find("/dev/zero: OBJ mesh: a character device"),
              std::string::npos)
        << meshError("/dev/zero");
    const std::string fifo = ::testing::TempDir() + "nvs_mesh_fifo.obj";
    ::unlink(fifo.c_str());
    ASSERT_EQ(::mkfifo(fifo.c_str(), 0600), 0);
    EXPECT_NE(meshError(fifo).find("a FIFO, not a regular file"), std::string::npos);
    ::unlink(fifo.c_str());
    EXPECT_NE(meshError("/nonexistent.obj").find("scene.toml:3"), std::string::npos);
}

TEST(ObjInput, FacesOutsideTheVerticesAreErrors) {
    const std::string head = "v 0 0 0\nv 1 0 0\nv 0 1 0\n";
    EXPECT_EQ(parseObjMesh(head + "f 1 2 3\n", "m.obj", {}, 0).triangleCount(), 1u);
    for (const char* f : {"f 1 2 9\n", "f -1 -2 -9\n"}) {
        try {
            parseObjMesh(head + f, "m.obj", {}, 0);
            ADD_FAILURE() << f;
        } catch (const SetupError& e) {
            EXPECT_NE(std::string(e.what()).find("m.obj"), std::string::npos) << e.what();
        }
    }
    try {
        parseObjMesh(head + "v 1 nan 0\n", "m.obj", {}, 0);
        ADD_FAILURE();
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("m.obj:4"), std::string::npos) << e.what();
    }
}

}  // namespace
}  // namespace nvs::scene
