// A camera preset naming a file the system refuses to look up: a name component longer than
// 255 bytes made std::filesystem::exists throw filesystem_error (ENAMETOOLONG), an exception
// other than SetupError (camera fuzz target); it is now "no file" with the preset's line.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include "sim/core/error.h"
#include "sim/sensor/camera.h"

namespace nvs::sensor {
namespace {

TEST(PresetInput, OverlongFileNameIsASetupError) {
    const std::filesystem::path config = std::filesystem::path(NVS_SOURCE_DIR) / "config";
    const std::string text =
        "name = \"x\"\n[spectral]\nresponse_file = \"spectra/" + std::string(300, 'a') + ".csv\"\n";
    try {
        parseCamera(config, text, "preset.toml");
        FAIL();
    } catch (const SetupError& e) {
        EXPECT_NE(std::string(e.what()).find("preset.toml:3"), std::string::npos) << e.what();
    }
    EXPECT_THROW(loadCamera(config, "/tmp/" + std::string(300, 'b') + ".toml"), SetupError);
}

}  // namespace
}  // namespace nvs::sensor
