#include "rt/cli/data_dirs.h"

#include <dlfcn.h>

#include <filesystem>
#include <system_error>

#include "python/bindings.h"
#include "rt/compose/environment.h"

namespace nvs::py {

namespace {

namespace fs = std::filesystem;

// An object of this module: dladdr names the file it was loaded from.
const char kAnchor = 0;

// The installed data, P/share/nvstim/config, where it exists: P the prefix the module is
// installed in (P/lib/python3/dist-packages/nvstim*.so, or P/lib/python3.X/dist-packages:
// three folders below P; a Debian package, `cmake --install --prefix P`), else the prefix it was
// built for (CMAKE_INSTALL_PREFIX). Empty where neither has it.
fs::path installedConfig() {
    std::error_code ec;
    Dl_info info{};
    if (dladdr(&kAnchor, &info) != 0 && info.dli_fname != nullptr) {
        const fs::path p = (fs::path(info.dli_fname).parent_path() / ".." / ".." / ".." / "share" /
                            "nvstim" / "config")
                               .lexically_normal();
        if (fs::is_directory(p, ec)) return p;
    }
    const fs::path p = fs::path(NVS_INSTALL_PREFIX) / "share" / "nvstim" / "config";
    if (fs::is_directory(p, ec)) return p.lexically_normal();
    return {};
}

}  // namespace

DataDirs moduleDataDirs(const std::optional<std::string>& configDir,
                        const std::optional<std::string>& cacheDir) {
    // rt/cli/data_dirs.h's rules with the installed data above in place of the executable's:
    // NVS_CONFIG_DIR, else the installed data, else the source tree's config/; the cache as the
    // command line's. Read at each call: os.environ changes made before it count.
    const auto env = [](const char* name) { return rt::environmentValue(name); };
    DataDirs d = cli::resolveDataDirs(env, fs::path());
    const char* given = env("NVS_CONFIG_DIR");
    if (given == nullptr || *given == '\0') {
        if (const fs::path installed = installedConfig(); !installed.empty()) d.config = installed;
    }
    if (configDir) d.config = *configDir;
    if (cacheDir) d.cache = *cacheDir;
    return d;
}

}  // namespace nvs::py
