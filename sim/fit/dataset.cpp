#include "sim/fit/dataset.h"

#include <toml++/toml.h>

#include <algorithm>
#include <cctype>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <fstream>
#include <map>
#include <memory>
#include <sstream>

#include "sim/core/config.h"
#include "sim/core/error.h"
#include "sim/core/fnv.h"
#include "sim/core/input_file.h"
#include "sim/io/frame_pattern.h"
#include "sim/io/image_file.h"
#include "sim/io/pnm.h"

namespace nvs::fit {

namespace {

namespace fs = std::filesystem;

[[noreturn]] void fail(const fs::path& file, const std::string& msg) {
    throw SetupError(FileLoc{file.string(), 0, 0}, msg);
}

// A TOML basic string holding `text` exactly: quotes, backslashes and control characters
// escaped.
std::string tomlQuoted(const std::string& text) {
    std::string q = "\"";
    for (const char c : text) {
        const auto u = static_cast<unsigned char>(c);
        if (c == '"' || c == '\\') {
            q += '\\';
            q += c;
        } else if (u < 0x20 || u == 0x7f) {
            char b[8];
            std::snprintf(b, sizeof b, "\\u%04x", u);
            q += b;
        } else {
            q += c;
        }
    }
    return q + "\"";
}

// [camera.settings] as preset overrides: every leaf under it as "a.b" = its TOML text, which
// the preset reader parses back as TOML (camera.h, Overrides).
void flattenSettings(const toml::table& t, const std::string& prefix, sensor::Overrides& out) {
    for (const auto& [k, node] : t) {
        const std::string key = prefix + std::string(k.str());
        if (const toml::table* sub = node.as_table()) {
            flattenSettings(*sub, key + ".", out);
            continue;
        }
        std::ostringstream s;
        if (const auto* str = node.as_string())
            s << tomlQuoted(str->get());
        else if (const auto* arr = node.as_array())
            s << toml::toml_formatter(*arr);
        else
            node.visit([&](const auto& v) { s << v; });
        out[key] = s.str();
    }
}

sensor::Overrides readSettings(const fs::path& tomlPath) {
    sensor::Overrides ov;
    try {
        const toml::table doc = toml::parse_file(tomlPath.string());
        if (const toml::table* s = doc["camera"]["settings"].as_table())
            flattenSettings(*s, "", ov);
    } catch (const toml::parse_error&) {
        // ConfigDocument reports the syntax error with its place.
    }
    return ov;
}

// Radiance units this reader converts, to the base unit of their kind.
struct UnitConversion {
    const char* name;
    const char* base;  // "W/m2/sr" or "pe/s/m2/sr"
    double factor;
};
constexpr UnitConversion kUnits[] = {
    {"W/m2/sr", "W/m2/sr", 1.0},       {"W/cm2/sr", "W/m2/sr", 1e4},
    {"uW/cm2/sr", "W/m2/sr", 1e-2},    {"nW/cm2/sr", "W/m2/sr", 1e-5},
    {"pe/s/m2/sr", "pe/s/m2/sr", 1.0}, {"pe/s/cm2/sr", "pe/s/m2/sr", 1e4},
};

// Factor from the given unit to Lpe [pe s⁻¹ m⁻² sr⁻¹].
// A W/m2/sr radiance is band-integrated with the camera's relative response, or over the box
// band [lo, hi] nm when `band` names one (the thesis's 480-940 nm radiances, §18.4).
double toLpe(const std::string& unit, const sensor::CameraParams& cam, const fs::path& configDir,
             const std::string& spectrum, const std::string& band, const FileLoc& where) {
    for (const UnitConversion& u : kUnits) {
        if (unit != u.name) continue;
        if (std::string(u.base) == "pe/s/m2/sr") return u.factor;
        if (band.empty())
            return u.factor * sensor::peRadiancePerBandRadiance(configDir, cam, spectrum);
        double lo = 0.0, hi = 0.0;
        if (std::sscanf(band.c_str(), "%lf-%lf", &lo, &hi) != 2 || !(lo > 0.0 && hi > lo))
            throw SetupError(where, "band '" + band + "': expected LO-HI in nm, e.g. \"480-940\"");
        const Spectrum box = Spectrum::fromFunction(
            [lo, hi](double nm) { return nm >= lo && nm <= hi ? 1.0 : 0.0; });
        return u.factor * sensor::peRadiancePerBandRadiance(
                              cam, sensor::spectrumShape(configDir, spectrum), box);
    }
    std::string known;
    for (const UnitConversion& u : kUnits)
        known += std::string(known.empty() ? "" : ", ") + u.name;
    throw SetupError(where,
                     "stimulus unit '" + unit + "' cannot be converted (known: " + known + ")");
}

// Frame numbers and files of [output] frames: a pattern over first_frame.., or a list.
struct FrameList {
    std::vector<long long> numbers;
    std::vector<fs::path> files;
};

long long numberInName(const fs::path& p) {
    const std::string s = p.stem().string();
    std::size_t end = s.size();
    while (end > 0 && !std::isdigit(static_cast<unsigned char>(s[end - 1])))
        --end;
    std::size_t begin = end;
    while (begin > 0 && std::isdigit(static_cast<unsigned char>(s[begin - 1])))
        --begin;
    if (begin == end) return -1;
    long long k = -1;
    // At most 15 digits (kMaxFrameNumber); a longer number is refused by the caller.
    if (end - begin > 15) return -2;
    std::from_chars(s.data() + begin, s.data() + end, k);
    return k;
}

FrameList listFrames(const ConfigTable& out, const fs::path& dir, const fs::path& tomlPath) {
    FrameList fl;
    const long long first = out.get<std::int64_t>("first_frame", 0);
    const bool counted = out.contains("count");
    const std::int64_t count = out.get<std::int64_t>("count", -1);
    if (first < 0 || first > kMaxFrameNumber)
        out.fail("first_frame", "must be in [0, " + std::to_string(kMaxFrameNumber) + "]");
    // Bounded before anything is allocated for the frames.
    if (counted && (count < kMinDatasetFrames || count > kMaxDatasetFrames)) {
        out.fail("count", "must be in [" + std::to_string(kMinDatasetFrames) + ", " +
                              std::to_string(kMaxDatasetFrames) + "] (" + std::to_string(count) +
                              ")");
    }
    bool isList = false;
    try {
        (void)out.optional<std::string>("frames");
    } catch (const SetupError&) {
        isList = true;  // not a string: a list of file names
    }
    if (isList) {
        const auto names = out.require<std::vector<std::string>>("frames");
        long long prev = -1;
        for (const std::string& n : names) {
            const long long k = numberInName(n);
            if (k == -2) out.fail("frames", "'" + n + "': frame number of more than 15 digits");
            if (k < 0) out.fail("frames", "'" + n + "' has no frame number in its name");
            if (fl.files.size() >= static_cast<std::size_t>(kMaxDatasetFrames))
                out.fail("frames", "more than " + std::to_string(kMaxDatasetFrames) + " frames");
            if (prev >= 0 && k != prev + 1) {
                out.fail("frames", "frames are not consecutive and increasing: '" + n +
                                       "' (frame " + std::to_string(k) + ") follows frame " +
                                       std::to_string(prev));
            }
            prev = k;
            fl.numbers.push_back(k);
            fl.files.push_back(dir / n);
        }
    } else {
        const std::string pattern = out.require<std::string>("frames");
        if (!io::hasFramePattern(pattern)) out.fail("frames", "needs {frame:06d} in it");
        long long n = count >= 0 ? count : 0;
        if (count < 0)
            while (n <= kMaxDatasetFrames &&
                   pathExists(dir / io::expandFramePattern(pattern, first + n)))
                ++n;
        if (n > kMaxDatasetFrames)
            out.fail("frames", "more than " + std::to_string(kMaxDatasetFrames) + " frames");
        for (long long k = first; k < first + n; ++k) {
            fl.numbers.push_back(k);
            fl.files.push_back(dir / io::expandFramePattern(pattern, k));
        }
        // A frame after a gap: the sequence has a hole.
        for (long long k = first + n + 1; k < first + n + 64 && count < 0; ++k) {
            if (pathExists(dir / io::expandFramePattern(pattern, k))) {
                fail(tomlPath, "[output] frames: frame " + std::to_string(first + n) +
                                   " is missing (frame " + std::to_string(k) + " exists)");
            }
        }
    }
    if (fl.files.empty()) fail(tomlPath, "[output] frames: no frame files found");
    if (fl.files.size() < static_cast<std::size_t>(kMinDatasetFrames)) {
        fail(tomlPath, "[output] frames: " + std::to_string(fl.files.size()) +
                           " frames; diagnose needs at least " + std::to_string(kMinDatasetFrames) +
                           " (2 warm-up, then at least 2 calibration and 2 held-out frames)");
    }
    for (std::size_t i = 0; i < fl.files.size(); ++i)
        if (!pathExists(fl.files[i])) {
            fail(fl.files[i], "frame " + std::to_string(fl.numbers[i]) + " is missing");
        }
    return fl;
}

}  // namespace

namespace {

// Cuts table [name] (to the next table header) out of TOML text; returns its body.
std::string cutTable(std::string& text, const std::string& name) {
    const std::string head = "[" + name + "]";
    std::istringstream in(text);
    std::string line, kept, body;
    bool inside = false;
    while (std::getline(in, line)) {
        std::string t = line.substr(0, line.find('#'));
        t.erase(0, t.find_first_not_of(" \t"));
        t.erase(t.find_last_not_of(" \t\r") + 1);
        if (!t.empty() && t[0] == '[') inside = t == head;
        (inside ? body : kept) += line + "\n";
    }
    text = kept;
    return body;
}

// The chain's halo and MCP saturation (sim/sensor stages 3b, 5b), as the preset sets them, are
// modelled by diagnose's own forward models (effects.h), like every effect it fits: their
// parameters move into `extra` and the chain runs without them, so a preset's effect is applied
// once, and a fitted one replaces it.
void absorbChainEffects(sensor::CameraParams& cam, FitEffects& extra) {
    extra.haloFraction = cam.halo_enabled ? cam.halo_fraction : 0.0;
    extra.haloRadius_um = cam.haloRadius_um();
    extra.satCharge_e = cam.mcpsat_enabled ? cam.mcpsat_pixel_charge_e : 0.0;
    extra.satRecharge_s = cam.mcpsat_recharge_s;
    cam.halo_enabled = false;
    cam.mcpsat_enabled = false;
}

}  // namespace

sensor::CameraParams loadModelCamera(const fs::path& configDir, const std::string& nameOrPath,
                                     const sensor::Overrides& overrides, FitEffects& extra) {
    const fs::path file = sensor::resolveCameraPath(configDir, nameOrPath);
    // A regular file only, bounded (a FIFO or /dev/zero as the preset is refused).
    std::string text = readInputFile(file, kMaxConfigFileBytes, "camera preset");
    std::string err;
    try {
        sensor::CameraParams cam = sensor::loadCamera(configDir, file.string(), overrides);
        absorbChainEffects(cam, extra);
        return cam;
    } catch (const SetupError& e) {
        err = e.what();
    }
    bool cut = false;
    // The chain reads [halo] and [mcp_saturation] itself (absorbed below); [veiling_glare] is
    // diagnose's alone.
    for (const char* t : {"veiling_glare"}) {
        if (err.find(std::string("'") + t) == std::string::npos &&
            text.find(std::string("[") + t + "]") == std::string::npos)
            continue;
        const std::string body = cutTable(text, t);
        if (body.empty()) continue;
        cut = true;
        const ConfigDocument doc =
            ConfigDocument::parseString(body, file.string() + " [" + t + "]");
        const ConfigTable tb = doc.root().table(t);
        const bool on = tb.get<bool>("enabled", true);
        if (std::string(t) == "halo") {
            extra.haloFraction = on ? tb.get<double>("fraction", 0.0) : 0.0;
            extra.haloRadius_um = tb.get<double>("radius_um", 0.0);
        } else if (std::string(t) == "mcp_saturation") {
            extra.satCharge_e = on ? tb.get<double>("pixel_charge_e", 0.0) : 0.0;
            extra.satRecharge_s = tb.get<double>("recharge_s", 0.0);
        } else {
            extra.glareFraction = on ? tb.get<double>("fraction", 0.0) : 0.0;
            extra.glareScale_um = tb.get<double>("scale_um", 0.0);
        }
        doc.finish();
    }
    if (!cut) throw SetupError(err);
    // Data files of the preset stay relative to its config folder.
    fs::path base = file.parent_path().parent_path();
    if (!pathExists(base / "spectra")) base = configDir;
    sensor::CameraParams cam = sensor::parseCamera(base, text, file.string(), overrides);
    absorbChainEffects(cam, extra);
    return cam;
}

Plane readFrame(const fs::path& path, int& width, int& height, int& maxValue) {
    const io::CountsFile c = io::readCounts(path);
    // A camera's counts: maximum value 2^n - 1 (255, 1023, 4095, 65535 ...).
    if (c.maxValue < 1 || ((c.maxValue + 1) & c.maxValue) != 0) {
        fail(path, "maximum value " + std::to_string(c.maxValue) +
                       " is not 2^n - 1 (a camera's full scale: 255, 1023, 4095, 65535)");
    }
    width = c.image.width();
    height = c.image.height();
    maxValue = c.maxValue;
    Plane p(static_cast<std::size_t>(width) * height);
    for (int y = 0; y < height; ++y)
        for (int x = 0; x < width; ++x)
            p[static_cast<std::size_t>(y) * width + x] = c.image(x, y);
    return p;
}

namespace {

// The stimulus images: read once per distinct file, converted to Lpe and checked.
void loadStimuli(Dataset& d, const ConfigTable& st, const std::vector<long long>& numbers,
                 const fs::path& configDir) {
    const std::string pattern = st.require<std::string>("radiance");
    std::vector<std::int64_t> index;
    if (st.contains("index")) {
        for (double v : st.require<std::vector<double>>("index")) {
            if (!(v >= 0.0) || v != std::floor(v))
                st.fail("index", "entries must be integers >= 0");
            index.push_back(static_cast<std::int64_t>(v));
        }
        if (index.size() != numbers.size()) {
            st.fail("index", "has " + std::to_string(index.size()) + " entries for " +
                                 std::to_string(numbers.size()) + " frames");
        }
    }
    std::map<std::uint64_t, int> byHash;
    std::map<std::string, int> byFile;
    d.spectrum = st.get<std::string>("spectrum", "flat");
    const std::string givenUnit = st.get<std::string>("unit", "");
    const std::string band = st.get<std::string>("band", "");
    for (std::size_t i = 0; i < numbers.size(); ++i) {
        const long long k = index.empty() ? numbers[i] : index[i];
        const fs::path file = d.dir / io::expandFramePattern(pattern, k);
        if (auto it = byFile.find(file.string()); it != byFile.end()) {
            d.stimulusOfFrame.push_back(it->second);
            continue;
        }
        if (!pathExists(file))
            fail(file, "stimulus for frame " + std::to_string(numbers[i]) + " is missing");
        io::RadianceFile r = io::readRadiance(file);
        if (r.image.width() != d.width || r.image.height() != d.height) {
            fail(file, "stimulus is " + std::to_string(r.image.width()) + "x" +
                           std::to_string(r.image.height()) + " but the frames are " +
                           std::to_string(d.width) + "x" + std::to_string(d.height));
        }
        const std::string unit =
            !givenUnit.empty() ? givenUnit : (r.unit.empty() ? "pe/s/m2/sr" : r.unit);
        d.unit = unit;
        const double k2 = toLpe(unit, d.camera, configDir, d.spectrum, band, st.location("unit"));
        Fnv1a h;
        for (int y = 0; y < d.height; ++y) {
            float* row = r.image.row(y);
            for (int x = 0; x < d.width; ++x) {
                if (!(row[x] >= 0.0f && row[x] < 3e38f)) {
                    fail(file, "pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                   ") is not a finite radiance >= 0");
                }
                row[x] = static_cast<float>(row[x] * k2);
            }
            h.bytes(row, sizeof(float) * static_cast<std::size_t>(d.width));
        }
        auto [it, fresh] = byHash.emplace(h.h, static_cast<int>(d.stimuli.size()));
        if (fresh) d.stimuli.push_back(std::move(r.image));
        byFile[file.string()] = it->second;
        d.stimulusOfFrame.push_back(it->second);
    }
}

// [stimulus] scenario: the scene rendered for every frame by the composition root's renderer.
void renderStimuli(Dataset& d, const ConfigTable& st, const std::vector<long long>& numbers,
                   const SceneStimulusFactory& renderScenario, const Progress& progress) {
    if (st.contains("radiance")) st.fail("radiance", "give either radiance or scenario, not both");
    const fs::path given = st.require<std::string>("scenario");
    d.scenario = given.is_relative() ? d.dir / given : given;
    if (!pathExists(d.scenario)) st.fail("scenario", "not found: " + d.scenario.string());
    if (!renderScenario) {
        st.fail("scenario", "a scenario stimulus needs the renderer of the nvstim command line");
    }
    try {
        d.scene = renderScenario(d.scenario, d.camera, d.presetFile, d.settings);
        d.sceneEffects = d.scene->stated();
        if (progress)
            progress("rendering " + d.scenario.string() + " for " + std::to_string(numbers.size()) +
                     " frames");
        d.stimuli = d.scene->render(numbers, d.frameRate_Hz, d.sceneEffects, progress);
    } catch (const SetupError& e) {
        st.fail("scenario", e.what());
    }
    d.frameNumbers = numbers;
    d.stimulusOfFrame.resize(numbers.size());
    for (std::size_t i = 0; i < numbers.size(); ++i)
        d.stimulusOfFrame[i] = static_cast<int>(i);
    d.unit = "pe/s/m2/sr";
}

}  // namespace

Dataset loadDataset(const fs::path& dir, const fs::path& configDir, const Progress& progress,
                    const SceneStimulusFactory& renderScenario) {
    const fs::path tomlPath = dir / "dataset.toml";
    if (!pathExists(tomlPath)) fail(dir, "no dataset.toml in the dataset folder");
    const ConfigDocument doc = ConfigDocument::parseFile(tomlPath);
    const ConfigTable root = doc.root();
    Dataset d;
    d.dir = dir;
    const ConfigTable cam = root.table("camera");
    d.preset = cam.require<std::string>("preset");
    cam.skip("settings");
    d.settings = readSettings(tomlPath);
    fs::path presetArg = d.preset;
    if (presetArg.extension() == ".toml" && presetArg.is_relative() && pathExists(dir / presetArg))
        presetArg = dir / presetArg;
    try {
        d.camera = loadModelCamera(configDir, presetArg.string(), d.settings, d.cameraExtra);
        d.presetFile = sensor::resolveCameraPath(configDir, presetArg.string());
    } catch (const SetupError& e) {
        fail(tomlPath, std::string("[camera] ") + e.what());
    }
    const ConfigTable out = root.table("output");
    // One frame file per call of the camera model, as `nvstim sensor` writes them: a field
    // in field scan, a frame in frame scan.
    d.frameRate_Hz = out.get<double>("frame_rate_hz", 1.0 / d.camera.integrationPeriod_s());
    if (!(d.frameRate_Hz > 0.0)) out.fail("frame_rate_hz", "must be > 0");
    const FrameList fl = listFrames(out, dir, tomlPath);
    d.firstFrame = fl.numbers.front();
    const ConfigTable st = root.table("stimulus");
    for (const ConfigTable& r : root.tableArray("roi")) {
        Roi roi{r.require<std::string>("name"), r.require<int>("x"), r.require<int>("y"),
                r.require<int>("w"), r.require<int>("h")};
        d.rois.push_back(roi);
    }
    for (std::size_t i = 0; i < fl.files.size(); ++i) {
        int w = 0, h = 0, maxv = 0;
        Plane p = readFrame(fl.files[i], w, h, maxv);
        if (i == 0) {
            d.width = w;
            d.height = h;
            d.frameMax_dc = maxv;
        } else if (w != d.width || h != d.height) {
            fail(fl.files[i], "frame is " + std::to_string(w) + "x" + std::to_string(h) +
                                  ", frame " + std::to_string(fl.numbers[0]) + " is " +
                                  std::to_string(d.width) + "x" + std::to_string(d.height));
        } else if (maxv != d.frameMax_dc) {
            fail(fl.files[i], "frame's full scale is " + std::to_string(maxv) + ", frame " +
                                  std::to_string(fl.numbers[0]) + "'s is " +
                                  std::to_string(d.frameMax_dc) + " (mixed bit depths)");
        }
        d.frames.push_back(std::move(p));
    }
    // Frames with nothing to fit: every sample the same, or each at 0 or full scale (dark or
    // clipped everywhere).
    bool varies = false, inRange = false;
    const float v0 = d.frames.front().front();
    for (const Plane& f : d.frames)
        for (const float v : f) {
            varies = varies || v != v0;
            inRange = inRange || (v > 0.0f && v < static_cast<float>(d.frameMax_dc));
        }
    if (!varies || !inRange) {
        fail(tomlPath,
             "[output] frames carry no signal: every sample is " +
                 (varies ? std::string("0 or full scale (") + std::to_string(d.frameMax_dc) + ")"
                         : std::to_string(static_cast<int>(v0))));
    }
    for (const Roi& r : d.rois)
        // In 64 bits: x + w of two large ints must not wrap past the check.
        if (r.w <= 0 || r.h <= 0 || r.x < 0 || r.y < 0 || std::int64_t{r.x} + r.w > d.width ||
            std::int64_t{r.y} + r.h > d.height) {
            fail(tomlPath, "[[roi]] '" + r.name + "' lies outside the frame");
        }
    const bool scenario = st.contains("scenario");
    if (!scenario) loadStimuli(d, st, fl.numbers, configDir);
    if (d.width != d.camera.width || d.height != d.camera.height) {
        fail(tomlPath, "frames are " + std::to_string(d.width) + "x" + std::to_string(d.height) +
                           " but camera '" + d.camera.name + "' is " +
                           std::to_string(d.camera.width) + "x" + std::to_string(d.camera.height) +
                           " (set width and height in [camera.settings])");
    }
    if (scenario) renderStimuli(d, st, fl.numbers, renderScenario, progress);
    doc.finish();
    return d;
}

void writeDataset(const Dataset& d, const fs::path& dir) {
    const bool scenario = !d.scenario.empty();
    if (!scenario) fs::create_directories(dir / "radiance");
    fs::create_directories(dir / "frames");
    for (std::size_t i = 0; !scenario && i < d.stimuli.size(); ++i)
        io::writePfm(
            dir / "radiance" / io::expandFramePattern("{frame:06d}.pfm", static_cast<long long>(i)),
            d.stimuli[i].cview());
    const int maxv = d.frameMax_dc;
    ImageU16 img(d.width, d.height);
    for (std::size_t k = 0; k < d.frames.size(); ++k) {
        for (int y = 0; y < d.height; ++y)
            for (int x = 0; x < d.width; ++x) {
                const float v = d.frames[k][static_cast<std::size_t>(y) * d.width + x];
                img(x, y) = static_cast<std::uint16_t>(std::clamp(std::lround(v), 0L, long{maxv}));
            }
        io::writePgm(
            dir / "frames" /
                io::expandFramePattern("{frame:06d}.pgm", d.firstFrame + static_cast<long long>(k)),
            img.cview(), maxv);
    }
    std::ofstream t(dir / "dataset.toml");
    t << "# Measured dataset (docs/contracts.md, \"Measured dataset\")\n";
    t << "[camera]\npreset = \"" << d.preset << "\"\n";
    if (!d.settings.empty()) {
        t << "[camera.settings]\n";
        for (const auto& [k, v] : d.settings)
            t << "\"" << k << "\" = " << v << "\n";
    }
    if (scenario) {
        t << "\n[stimulus]\nscenario = \"" << d.scenario.generic_string() << "\"\n";
    } else {
        t << "\n[stimulus]\nradiance = \"radiance/{frame:06d}.pfm\"\nunit = \"pe/s/m2/sr\"\n";
        t << "index = [";
        for (std::size_t k = 0; k < d.stimulusOfFrame.size(); ++k)
            t << (k ? ", " : "") << d.stimulusOfFrame[k];
        t << "]\n";
    }
    t << "\n[output]\nframes = \"frames/{frame:06d}.pgm\"\n";
    char buf[64];
    std::snprintf(buf, sizeof buf, "%.9g", d.frameRate_Hz);
    t << "frame_rate_hz = " << buf << "\nfirst_frame = " << d.firstFrame
      << "\ncount = " << d.frames.size() << "\n";
    for (const Roi& r : d.rois)
        t << "\n[[roi]]\nname = \"" << r.name << "\"\nx = " << r.x << "\ny = " << r.y
          << "\nw = " << r.w << "\nh = " << r.h << "\n";
    if (!t) fail(dir / "dataset.toml", "cannot write");
}

}  // namespace nvs::fit
