#include "rt/cli/data_dirs.h"

#include <cstdlib>
#include <system_error>

#include "rt/compose/environment.h"

namespace nvs::cli {

namespace {

// A variable set to an empty string counts as unset (as in a shell's `VAR= nvstim ...`).
const char* nonEmpty(const char* value) {
    return value != nullptr && *value != '\0' ? value : nullptr;
}

}  // namespace

DataDirs resolveDataDirs(const std::function<const char*(const char*)>& env,
                         const std::filesystem::path& exeDir) {
    DataDirs d;
    // Config: the override, then an installed tree beside the binary, then the source tree.
    std::error_code ec;
    const std::filesystem::path installed = exeDir / ".." / "share" / "nvstim" / "config";
    if (const char* c = nonEmpty(env("NVS_CONFIG_DIR"))) {
        d.config = c;
    } else if (!exeDir.empty() && std::filesystem::is_directory(installed, ec)) {
        d.config = installed.lexically_normal();
    } else {
        d.config = NVS_DEFAULT_CONFIG_DIR;
    }
    // Cache: the XDG base-directory rules, with our own override first. The folder layout
    // (atmosphere-<key>.bin directly inside) is what earlier versions wrote.
    if (const char* c = nonEmpty(env("NVS_CACHE_DIR"))) {
        d.cache = c;
    } else if (const char* x = nonEmpty(env("XDG_CACHE_HOME"))) {
        d.cache = std::filesystem::path(x) / "nvstim";
    } else if (const char* h = nonEmpty(env("HOME"))) {
        d.cache = std::filesystem::path(h) / ".cache" / "nvstim";
    } else {
        d.cache = std::filesystem::temp_directory_path() / "nvstim-cache";
    }
    return d;
}

DataDirs resolveDataDirs() {
    std::error_code ec;
    const std::filesystem::path exe = std::filesystem::read_symlink("/proc/self/exe", ec);
    return resolveDataDirs([](const char* name) { return rt::environmentValue(name); },
                           ec ? std::filesystem::path() : exe.parent_path());
}

}  // namespace nvs::cli
