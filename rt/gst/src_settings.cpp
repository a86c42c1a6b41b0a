#include "rt/gst/src_settings.h"

#include <cmath>
#include <cstring>
#include <system_error>

#include "rt/cli/data_dirs.h"
#include "rt/compose/environment.h"
#include "sim/core/error.h"
#include "sim/sensor/camera.h"

namespace nvs::gst {

namespace {

// A variable set to an empty string counts as unset (rt/cli/data_dirs.cpp's rule).
const char* nonEmpty(const char* value) {
    return value != nullptr && *value != '\0' ? value : nullptr;
}

bool isDirectory(const std::filesystem::path& p) {
    std::error_code ec;
    return !p.empty() && std::filesystem::is_directory(p, ec);
}

}  // namespace

std::vector<std::string> splitSets(const std::string& text) {
    std::vector<std::string> items;
    std::size_t pos = 0;
    while (pos <= text.size()) {
        std::size_t end = text.find_first_of(",;", pos);
        if (end == std::string::npos) end = text.size();
        std::size_t a = pos, b = end;
        while (a < b && (text[a] == ' ' || text[a] == '\t'))
            ++a;
        while (b > a && (text[b - 1] == ' ' || text[b - 1] == '\t'))
            --b;
        if (b > a) items.push_back(text.substr(a, b - a));
        pos = end + 1;
    }
    return items;
}

DataDirs pluginDataDirs(const SrcSettings& s, const std::filesystem::path& pluginDir) {
    DataDirs d;
    const std::filesystem::path besidePlugin =
        pluginDir.empty() ? std::filesystem::path()
                          : (pluginDir / NVS_GST_PLUGIN_TO_CONFIG).lexically_normal();
    if (!s.configDir.empty()) {
        d.config = s.configDir;
    } else if (const char* c = nonEmpty(rt::environmentValue("NVS_CONFIG_DIR"))) {
        d.config = c;
    } else if (isDirectory(besidePlugin)) {
        d.config = besidePlugin;
    } else if (isDirectory(NVS_GST_INSTALLED_CONFIG_DIR)) {
        d.config = NVS_GST_INSTALLED_CONFIG_DIR;
    } else {
        d.config = NVS_DEFAULT_CONFIG_DIR;
    }
    if (!s.cacheDir.empty()) {
        d.cache = s.cacheDir;
    } else if (const char* c = nonEmpty(rt::environmentValue("NVS_CACHE_DIR"))) {
        d.cache = c;
    } else if (const char* x = nonEmpty(rt::environmentValue("XDG_CACHE_HOME"))) {
        d.cache = std::filesystem::path(x) / "nvstim";
    } else if (const char* h = nonEmpty(rt::environmentValue("HOME"))) {
        d.cache = std::filesystem::path(h) / ".cache" / "nvstim";
    } else {
        d.cache = std::filesystem::temp_directory_path() / "nvstim-cache";
    }
    return d;
}

rt::SessionOptions sessionOptions(const SrcSettings& s, const std::filesystem::path& pluginDir) {
    rt::SessionOptions o;
    if (s.scenario.empty()) throw SetupError("scenario: the property is not set");
    if (s.frames == 0 || s.frames < -1) {
        throw SetupError("frames: must be -1 (the scenario's duration) or at least 1");
    }
    if (s.frames > 0) o.frames = s.frames;
    // In `nvstim run`'s order (rt/cli/cmd_run.cpp), so that the first mistake is reported as
    // it reports it: the data folders, the scenario (a path, or a bare name of a shipped
    // scenario), the camera overrides.
    o.dirs = pluginDataDirs(s, pluginDir);
    o.scenario = cli::resolveScenario(s.scenario, cli::scenariosDir(o.dirs));
    o.clock = s.clock;
    o.channel = s.channel;
    if (!s.camera.empty()) o.overrides.cameraPreset = s.camera;
    o.overrides.cameraSets = sensor::parseOverrides(splitSets(s.sets));
    if (!s.telemetry.empty()) o.telemetry = s.telemetry;
    return o;
}

std::int64_t exposureMonotonic_ns(const rt::PulledFrame& f) {
    return f.emitMonotonic_ns - std::llround((f.emit_s - f.t_sample_s) * 1e9);
}

void packGray(const rt::PulledFrame& f, unsigned char* dst, std::size_t stride_bytes) {
    const bool wide = f.bits > 8;
    const int shift = wide ? 16 - f.bits : 8 - f.bits;
    const std::size_t w = static_cast<std::size_t>(f.width);
    const std::size_t rowBytes = w * (wide ? 2 : 1);
    for (int y = 0; y < f.height; ++y) {
        const std::uint16_t* row = f.counts.data() + static_cast<std::size_t>(y) * w;
        unsigned char* out = dst + static_cast<std::size_t>(y) * stride_bytes;
        if (wide) {
            for (std::size_t x = 0; x < w; ++x) {
                const auto v = static_cast<std::uint16_t>(row[x] << shift);
                out[2 * x] = static_cast<unsigned char>(v & 0xff);  // little-endian
                out[2 * x + 1] = static_cast<unsigned char>(v >> 8);
            }
        } else {
            for (std::size_t x = 0; x < w; ++x)
                out[x] = static_cast<unsigned char>(row[x] << shift);
        }
        if (stride_bytes > rowBytes) std::memset(out + rowBytes, 0, stride_bytes - rowBytes);
    }
}

}  // namespace nvs::gst
