// The data folders an nvstim process uses (rt/cli/data_dirs.h): overrides, an installed tree
// beside the executable, the source tree; the cache by the XDG rules.

#include "rt/cli/data_dirs.h"

#include <gtest/gtest.h>

#include <filesystem>
#include <map>
#include <string>

namespace nvs::cli {
namespace {

namespace fs = std::filesystem;

DataDirs resolve(const std::map<std::string, std::string>& env, const fs::path& exeDir) {
    return resolveDataDirs(
        [&](const char* name) -> const char* {
            const auto it = env.find(name);
            return it == env.end() ? nullptr : it->second.c_str();
        },
        exeDir);
}

TEST(DataDirs, EnvironmentOverridesComeFirst) {
    const DataDirs d = resolve({{"NVS_CONFIG_DIR", "/c"},
                                {"NVS_CACHE_DIR", "/k"},
                                {"XDG_CACHE_HOME", "/x"},
                                {"HOME", "/h"}},
                               "/nowhere/bin");
    EXPECT_EQ(d.config, fs::path("/c"));
    EXPECT_EQ(d.cache, fs::path("/k"));
}

TEST(DataDirs, CacheFollowsXdgThenHome) {
    EXPECT_EQ(resolve({{"XDG_CACHE_HOME", "/x"}, {"HOME", "/h"}}, "").cache, fs::path("/x/nvstim"));
    EXPECT_EQ(resolve({{"XDG_CACHE_HOME", ""}, {"HOME", "/h"}}, "").cache,
              fs::path("/h/.cache/nvstim"));
}

TEST(DataDirs, InstalledTreeBesideTheExecutableThenTheSourceTree) {
    const fs::path prefix = fs::temp_directory_path() / "nvs_data_dirs_test";
    fs::remove_all(prefix);
    fs::create_directories(prefix / "bin");
    // No share/nvstim/config beside bin/: the source tree's config/ compiled in.
    const DataDirs source = resolve({{"HOME", "/h"}}, prefix / "bin");
    EXPECT_EQ(source.config, fs::path(NVS_SOURCE_DIR) / "config");
    fs::create_directories(prefix / "share" / "nvstim" / "config");
    const DataDirs installed = resolve({{"HOME", "/h"}}, prefix / "bin");
    EXPECT_EQ(installed.config, prefix / "share" / "nvstim" / "config");
    fs::remove_all(prefix);
}

// The shipped scenarios lie beside the config folder: PREFIX/share/nvstim/scenarios installed,
// the source tree's scenarios/, NVS_CONFIG_DIR's sibling.
TEST(DataDirs, ScenariosLieBesideTheConfigFolder) {
    const fs::path prefix = fs::temp_directory_path() / "nvs_data_dirs_scenarios_test";
    fs::remove_all(prefix);
    fs::create_directories(prefix / "bin");
    EXPECT_EQ(scenariosDir(resolve({}, prefix / "bin")), fs::path(NVS_SOURCE_DIR) / "scenarios");
    fs::create_directories(prefix / "share" / "nvstim" / "config");
    EXPECT_EQ(scenariosDir(resolve({}, prefix / "bin")), prefix / "share" / "nvstim" / "scenarios");
    EXPECT_EQ(scenariosDir(resolve({{"NVS_CONFIG_DIR", "/opt/x/config/"}}, "")),
              fs::path("/opt/x/scenarios"));
    fs::remove_all(prefix);
}

}  // namespace
}  // namespace nvs::cli
