#include "rt/cli/data_dirs.h"

#include <algorithm>
#include <cstdlib>
#include <system_error>
#include <utility>

#include "rt/compose/environment.h"
#include "sim/core/config.h"
#include "sim/core/error.h"

namespace nvs::cli {

namespace {

// A variable set to an empty string counts as unset (as in a shell's `VAR= nvstim ...`).
const char* nonEmpty(const char* value) {
    return value != nullptr && *value != '\0' ? value : nullptr;
}

// A name as typed, without a trailing '/', "/scenario.toml" or ".toml": what is compared with
// the shipped names.
std::string bareName(const std::string& arg) {
    std::filesystem::path p = arg;
    while (!p.empty() && !p.has_filename() && p.has_parent_path() && p != p.parent_path())
        p = p.parent_path();  // "a/b/" -> "a/b"
    if (p.filename() == "scenario.toml") p = p.parent_path();
    if (p.extension() == ".toml") p.replace_extension();
    return p.filename().string();
}

// Up to three names near `name` (within an edit distance of half its length, at least 2),
// nearest first (ties in name order).
std::string nearestNames(const std::string& name, const std::vector<std::string>& names) {
    std::vector<std::pair<std::size_t, std::string>> ranked;
    const std::size_t limit = std::max<std::size_t>(2, name.size() / 2);
    for (const std::string& n : names)
        if (const std::size_t d = editDistance(name, n); d <= limit) ranked.emplace_back(d, n);
    std::sort(ranked.begin(), ranked.end());
    std::string out;
    for (std::size_t i = 0; i < ranked.size() && i < 3; ++i)
        out += (i > 0 ? ", " : "") + ranked[i].second;
    return out;
}

}  // namespace

std::filesystem::path scenariosDir(const DataDirs& dirs) {
    std::filesystem::path config = dirs.config;
    if (!config.has_filename()) config = config.parent_path();  // "PREFIX/config/"
    return (config.parent_path() / "scenarios").lexically_normal();
}

std::vector<std::string> scenarioNames(const std::filesystem::path& dir) {
    std::vector<std::string> names;
    std::error_code ec;
    for (std::filesystem::directory_iterator it(dir, ec), end; !ec && it != end; it.increment(ec)) {
        if (std::filesystem::is_regular_file(it->path() / "scenario.toml", ec))
            names.push_back(it->path().filename().string());
    }
    std::sort(names.begin(), names.end());
    return names;
}

std::string resolveScenario(const std::string& arg, const std::filesystem::path& dir) {
    std::error_code ec;
    if (std::filesystem::exists(arg, ec)) return arg;
    const bool bare = !arg.empty() && arg.find('/') == std::string::npos;
    if (bare) {
        if (std::filesystem::is_regular_file(dir / arg / "scenario.toml", ec))
            return (dir / arg).string();
        if (std::filesystem::is_regular_file(dir / (arg + ".toml"), ec))
            return (dir / (arg + ".toml")).string();
    }
    const std::vector<std::string> names = scenarioNames(dir);
    std::string msg = "scenario '" + arg + "': no such file or folder";
    msg += bare ? ", and no scenario of that name in " : " (a bare name is looked up in ";
    msg += dir.string() + (bare ? "" : ")");
    const std::string near = nearestNames(bareName(arg), names);
    if (names.empty()) {
        msg += std::filesystem::is_directory(dir, ec) ? " (it holds no scenario)"
                                                      : " (no such folder)";
    } else if (near.empty()) {
        msg += "; `nvstim list scenarios` names them";
    } else {
        msg += "; nearest: " + near + " (`nvstim list scenarios` names them all)";
    }
    throw SetupError(msg);
}

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
