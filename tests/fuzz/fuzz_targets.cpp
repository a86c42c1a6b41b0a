#include "tests/fuzz/fuzz_targets.h"

#include <stdlib.h>
#include <sys/stat.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "drivers/can/can.h"
#include "drivers/serial/fake/fake_serial.h"
#include "drivers/serial/serial.h"
#include "rt/compose/scenario.h"
#include "rt/telemetry/sources.h"
#include "rt/telemetry/track.h"
#include "sim/core/csv.h"
#include "sim/core/error.h"
#include "sim/core/output_file.h"
#include "sim/fit/dataset.h"
#include "sim/io/exr.h"
#include "sim/io/frame_pattern.h"
#include "sim/io/image_file.h"
#include "sim/io/pnm.h"
#include "sim/scene/scene.h"
#include "sim/sensor/camera.h"

namespace nvs::fuzz {

namespace {

// A property the parsers promise; broken, the process ends (a finding for libFuzzer, a crash
// of the corpus test) after naming the property.
void requireAt(bool ok, const char* what, int line) {
    if (ok) return;
    std::fprintf(stderr, "fuzz_targets.cpp:%d: property broken: %s\n", line, what);
    std::abort();
}
#define require(cond) requireAt((cond), #cond, __LINE__)

std::string text(const std::uint8_t* data, std::size_t size) {
    return std::string(reinterpret_cast<const char*>(data), size);
}

const std::filesystem::path& configDir() {
    static const std::filesystem::path dir = std::filesystem::path(NVS_SOURCE_DIR) / "config";
    return dir;
}

// Runs f, letting the one expected exception go: a SetupError for bad input.
template <typename F>
int expectSetupError(F f) {
    try {
        f();
    } catch (const SetupError&) {
    }
    return 0;
}

// The platform state handed on is finite: the telemetry boundary let nothing else through.
void requireFinite(const msg::PlatformState& p) {
    for (const double v : {p.lat_deg, p.lon_deg, p.alt_m, p.yaw_rad, p.pitch_rad, p.roll_rad,
                           p.utc_unix_s, p.gain_V, p.gate_s}) {
        require(std::isfinite(v));
    }
    require(p.lat_deg >= -90.0 && p.lat_deg <= 90.0);
}

// Serial bytes through the input the program uses (SerialInput over an in-memory port) and
// the platform track, sampled after each chunk.
void serialInput(const std::uint8_t* data, std::size_t size, rt::SerialInput::Proto proto) {
    auto port = std::make_unique<drivers::FakeSerialPort>();
    drivers::FakeSerialPort* fake = port.get();
    msg::PlatformState initial;
    rt::TelemetryPlatform platform(
        std::make_unique<rt::SerialInput>(std::move(port), "fuzz", 115200, proto), initial, 0.5,
        0.1, false);
    msg::PlatformState out;
    double t_s = 0.0;
    for (std::size_t at = 0; at < size; at += 64, t_s += 0.01) {
        fake->pushBytes(data + at, std::min<std::size_t>(64, size - at));
        platform.sample(t_s, t_s, out);
        requireFinite(out);
    }
}

// Serial bytes as the target sees them: the input itself (first byte even), or (first byte
// odd) the rest re-framed with correct checksums, so that the fuzzer reaches what lies behind
// a CRC or an XOR it cannot guess. NMEA: each line a sentence body, "*hh\r\n" appended.
// MAVLink: records [flags][length][payload…], flags choosing v1/v2 and HEARTBEAT, ATTITUDE or
// GLOBAL_POSITION_INT.
std::string framed(const std::uint8_t* data, std::size_t size, rt::SerialInput::Proto proto) {
    if (size == 0 || (data[0] & 1) == 0) return text(data, size);
    std::string out;
    if (proto == rt::SerialInput::Proto::Nmea) {
        const std::string all = text(data + 1, size - 1);
        for (std::size_t pos = 0; pos < all.size();) {
            const std::size_t eol = std::min(all.find('\n', pos), all.size());
            out += drivers::nmeaWithChecksum("$" + all.substr(pos, eol - pos));
            pos = eol + 1;
        }
        return out;
    }
    static constexpr std::uint32_t kIds[3] = {drivers::kMavlinkHeartbeat, drivers::kMavlinkAttitude,
                                              drivers::kMavlinkGlobalPositionInt};
    for (std::size_t i = 1; i + 2 <= size;) {
        const int version = (data[i] & 2) != 0 ? 2 : 1;
        const std::uint32_t id = kIds[(data[i] >> 2) % 3];
        const std::size_t n = std::min<std::size_t>(data[i + 1] % 40, size - i - 2);
        const std::vector<std::uint8_t> f = drivers::mavlinkFrame(version, id, data + i + 2, n);
        out.append(reinterpret_cast<const char*>(f.data()), f.size());
        i += 2 + n;
    }
    return out;
}

}  // namespace

int dbc(const std::uint8_t* data, std::size_t size) {
    return expectSetupError([&] {
        const drivers::DbcDatabase db = drivers::DbcDatabase::parse(text(data, size), "fuzz.dbc");
        std::uint8_t frame[64];
        for (std::size_t i = 0; i < sizeof frame; ++i)
            frame[i] = data[size == 0 ? 0 : i % size];
        for (const drivers::DbcMessage& m : db.messages()) {
            for (const drivers::DbcSignal& s : m.signals) {
                double v = 0.0;
                if (!drivers::decodeSignal(s, frame, m.size, &v)) continue;
                (void)drivers::inDeclaredRange(s, v);
                std::uint8_t enc[64] = {};
                drivers::encodeSignal(s, v, enc, m.size);
            }
        }
    });
}

int candump(const std::uint8_t* data, std::size_t size) {
    // Every line through the candump parser; a parsed frame formats back to a line that parses
    // to the same frame, and decoded frames (the shipped DBC) keep the track finite.
    static const drivers::DbcDatabase db =
        drivers::DbcDatabase::load((configDir() / "can" / "nvstim.dbc").string());
    rt::CanDecoder decoder{db};
    msg::PlatformState initial;
    rt::PlatformTrack track(initial, 0.5, 0.1);
    const std::string_view all(reinterpret_cast<const char*>(data), size);
    for (std::size_t pos = 0; pos < all.size();) {
        const std::size_t eol = std::min(all.find('\n', pos), all.size());
        const std::string_view line = all.substr(pos, eol - pos);
        pos = eol + 1;
        double t_s = 0.0;
        drivers::CanFrame f;
        if (!drivers::parseCandumpLine(line, &t_s, &f)) continue;
        require(std::isfinite(t_s) && t_s >= 0.0);
        char buf[256];
        const std::size_t n = drivers::formatCandumpLine(t_s, "can0", f, buf, sizeof buf);
        require(n > 0);
        double t2 = 0.0;
        drivers::CanFrame g;
        require(drivers::parseCandumpLine(std::string_view(buf, n), &t2, &g));
        require(g.id == f.id && g.extended == f.extended && g.fd == f.fd && g.rtr == f.rtr);
        rt::TelemetryUpdate u;
        if (decoder.decode(f, t_s, &u)) track.apply(u);
        msg::PlatformState out;
        track.sample(t_s, out);
        requireFinite(out);
    }
    return 0;
}

int nmea(const std::uint8_t* raw, std::size_t rawSize) {
    const std::string bytes = framed(raw, rawSize, rt::SerialInput::Proto::Nmea);
    const auto* data = reinterpret_cast<const std::uint8_t*>(bytes.data());
    const std::size_t size = bytes.size();
    drivers::NmeaParser parser;
    for (std::size_t i = 0; i < size; ++i) {
        drivers::NmeaSentence s;
        if (!parser.push(data[i], &s)) continue;
        require(s.timeOfDay_s == -1.0 || (s.timeOfDay_s >= 0.0 && s.timeOfDay_s < 86401.0));
        require(std::fabs(s.lat_deg) <= 90.0 && std::fabs(s.lon_deg) <= 180.0);
        require(std::isfinite(s.alt_m) && s.heading_deg >= 0.0 && s.heading_deg <= 360.0);
    }
    serialInput(data, size, rt::SerialInput::Proto::Nmea);
    return 0;
}

int mavlink(const std::uint8_t* raw, std::size_t rawSize) {
    const std::string bytes = framed(raw, rawSize, rt::SerialInput::Proto::Mavlink);
    const auto* data = reinterpret_cast<const std::uint8_t*>(bytes.data());
    const std::size_t size = bytes.size();
    drivers::MavlinkParser parser;
    for (std::size_t i = 0; i < size; ++i) {
        drivers::MavlinkMessage m;
        if (!parser.push(data[i], &m)) continue;
        drivers::MavlinkAttitude a;
        if (drivers::decodeAttitude(m, &a)) {
            require(std::fabs(a.roll_rad) <= 3.1416f && std::fabs(a.pitch_rad) <= 3.1416f &&
                    std::fabs(a.yaw_rad) <= 3.1416f);
        }
        drivers::MavlinkGlobalPosition g;
        if (drivers::decodeGlobalPosition(m, &g)) {
            require(std::fabs(g.lat_deg) <= 90.0 && std::fabs(g.lon_deg) <= 180.0);
        }
    }
    serialInput(data, size, rt::SerialInput::Proto::Mavlink);
    return 0;
}

int scenario(const std::uint8_t* data, std::size_t size) {
    return expectSetupError([&] {
        // Named as a scenario folder beside the shipped ones, so that "../rit/scene.toml" and
        // "../airborne-pass/flight.candump" in a seed resolve.
        static const std::string name =
            (std::filesystem::path(NVS_SOURCE_DIR) / "scenarios" / "fuzz" / "scenario.toml")
                .string();
        const rt::Scenario sc = rt::parseScenario(text(data, size), name, configDir());
        require(sc.rate.valid());
        require(!sc.duration_s || (*sc.duration_s > 0.0 && *sc.duration_s <= rt::kMaxDuration_s));
        requireFinite(sc.platform);
    });
}

int camera(const std::uint8_t* data, std::size_t size) {
    return expectSetupError(
        [&] { (void)sensor::parseCamera(configDir(), text(data, size), "fuzz/camera.toml"); });
}

int csv(const std::uint8_t* data, std::size_t size) {
    return expectSetupError([&] {
        const CsvTable t = CsvTable::parse(text(data, size), "fuzz.csv");
        for (std::size_t r = 0; r < t.rowCount(); ++r) {
            for (std::size_t c = 0; c < t.header().size(); ++c) {
                try {
                    (void)t.number(r, c);
                } catch (const SetupError&) {
                }
            }
        }
        (void)t.commentValue("source");
    });
}

int obj(const std::uint8_t* data, std::size_t size) {
    return expectSetupError([&] {
        const scene::Mesh m = scene::parseObjMesh(text(data, size), "fuzz.obj", {}, 0);
        for (const std::uint32_t i : m.triangles)
            require(i < m.vertexCount());
        for (const float v : m.vertices_m)
            require(std::isfinite(v));
    });
}

int image(const std::uint8_t* data, std::size_t size) {
    // The format by its magic, as a file's extension would choose it; small limits keep each
    // run fast (the limits themselves are checked before any pixel is allocated).
    io::ImageLimits limits;
    limits.maxWidth = 512;
    limits.maxHeight = 512;
    const std::string_view bytes(reinterpret_cast<const char*>(data), size);
    return expectSetupError([&] {
        if (bytes.substr(0, 2) == "P5") {
            const ImageU16 img = io::parsePgm(bytes, "fuzz.pgm", limits);
            require(img.width() <= 512 && img.height() <= 512);
        } else if (bytes.substr(0, 2) == "Pf" || bytes.substr(0, 2) == "PF") {
            const ImageF img = io::parsePfm(bytes, "fuzz.pfm", limits);
            require(img.width() <= 512 && img.height() <= 512);
        } else {
            const io::ExrImage r = io::parseExr(bytes, "fuzz.exr", limits);
            require(r.image.width() <= 512 && r.image.height() <= 512);
        }
    });
}

namespace {

// A folder of the process's own under $TMPDIR, removed at exit.
struct PrivateFolder {
    std::filesystem::path path;
    explicit PrivateFolder(const char* pattern) {
        std::string t = (std::filesystem::temp_directory_path() / pattern).string();
        if (::mkdtemp(t.data()) == nullptr) std::abort();
        path = t;
    }
    ~PrivateFolder() {
        std::error_code ec;
        std::filesystem::remove_all(path, ec);
    }
    PrivateFolder(const PrivateFolder&) = delete;
    PrivateFolder& operator=(const PrivateFolder&) = delete;
};

}  // namespace

// A dataset folder from one input: parts separated by a line "%%"; the first is dataset.toml,
// each other part a file named by its magic (Pf/PF: radiance/NNNNNN.pfm; \x89PNG:
// frames/NNNNNN.png; anything else frames/NNNNNN.pgm), numbered in order from 0. Written to a
// private folder (emptied for each input) and read by fit::loadDataset with the shipped
// presets; a dataset accepted keeps the loader's promises.
int dataset(const std::uint8_t* data, std::size_t size) {
    namespace fs = std::filesystem;
    static const PrivateFolder root("nvs-fuzz-dataset-XXXXXX");
    const fs::path& dir = root.path;
    std::error_code ec;
    for (const char* sub : {"frames", "radiance"}) {
        fs::remove_all(dir / sub, ec);
        fs::create_directories(dir / sub, ec);
    }
    const std::string_view all(reinterpret_cast<const char*>(data), size);
    int frames = 0, radiances = 0;
    std::size_t at = 0;
    for (int part = 0; at <= all.size() && part < 64; ++part) {
        std::size_t end = all.find("\n%%\n", at);
        if (end == std::string_view::npos) end = all.size();
        const std::string_view bytes = all.substr(at, end - at);
        fs::path name;
        if (part == 0)
            name = dir / "dataset.toml";
        else if (bytes.substr(0, 2) == "Pf" || bytes.substr(0, 2) == "PF")
            name = dir / "radiance" / io::expandFramePattern("{frame:06d}.pfm", radiances++);
        else if (bytes.substr(0, 4) == "\x89PNG")
            name = dir / "frames" / io::expandFramePattern("{frame:06d}.png", frames++);
        else
            name = dir / "frames" / io::expandFramePattern("{frame:06d}.pgm", frames++);
        std::FILE* f = std::fopen(name.c_str(), "wb");
        if (f == nullptr) std::abort();
        std::fwrite(bytes.data(), 1, bytes.size(), f);
        std::fclose(f);
        at = end + 4;
    }
    return expectSetupError([&] {
        const fit::Dataset d = fit::loadDataset(dir, configDir());
        require(d.frameCount() >= static_cast<std::size_t>(fit::kMinDatasetFrames));
        require(d.frameCount() <= static_cast<std::size_t>(fit::kMaxDatasetFrames));
        require(d.width == d.camera.width && d.height == d.camera.height);
        require(d.frameMax_dc >= 1 && ((d.frameMax_dc + 1) & d.frameMax_dc) == 0);
        require(d.stimulusOfFrame.size() == d.frameCount());
        bool signal = false;
        for (const fit::Plane& p : d.frames) {
            require(p.size() == static_cast<std::size_t>(d.width) * d.height);
            for (const float v : p) {
                require(v >= 0.0f && v <= static_cast<float>(d.frameMax_dc));
                signal = signal || (v > 0.0f && v < static_cast<float>(d.frameMax_dc));
            }
        }
        require(signal);
        for (const fit::Roi& r : d.rois)
            require(r.x >= 0 && r.y >= 0 && r.w > 0 && r.h > 0 &&
                    std::int64_t{r.x} + r.w <= d.width && std::int64_t{r.y} + r.h <= d.height);
        for (const int s : d.stimulusOfFrame)
            require(s >= 0 && static_cast<std::size_t>(s) < d.stimuli.size());
    });
}

// The output layer's path checks (sim/core/output_file.h) in a private folder that holds an
// input folder, a previous report, a user's folder, a file, a link, a loop of links and a FIFO.
// Each input line declares one path: 'i' an input, 'f' a file output, 'd' a report folder,
// then the path inside the private folder ("/" and ".." components dropped). The outputs
// accepted are written and committed; then no temporary is left, the user's files and the
// inputs are as they were (unless an accepted file output named that very file), and every
// report folder holds its marker.
int outputPaths(const std::uint8_t* data, std::size_t size) {
    namespace fs = std::filesystem;
    static const PrivateFolder root("nvs-fuzz-outputs-XXXXXX");
    const fs::path& dir = root.path;
    std::error_code ec;
    for (const auto& e : fs::directory_iterator(dir, ec))
        fs::remove_all(e.path(), ec);
    const auto put = [](const fs::path& p, const std::string& text) {
        std::FILE* f = std::fopen(p.c_str(), "wb");
        if (f == nullptr) std::abort();
        std::fputs(text.c_str(), f);
        std::fclose(f);
    };
    const auto get = [](const fs::path& p) {
        std::string t;
        if (std::FILE* f = std::fopen(p.c_str(), "rb")) {
            char b[256];
            std::size_t n = 0;
            while ((n = std::fread(b, 1, sizeof b, f)) > 0)
                t.append(b, n);
            std::fclose(f);
        }
        return t;
    };
    fs::create_directories(dir / "in" / "sub", ec);
    fs::create_directories(dir / "rep", ec);
    fs::create_directories(dir / "plain", ec);
    put(dir / "in" / "data.toml", "input");
    put(dir / "rep" / ".marker", "");
    put(dir / "plain" / "keep", "user");
    put(dir / "file.json", "old");
    fs::create_symlink(dir / "file.json", dir / "link", ec);
    fs::create_symlink(dir / "loop", dir / "loop", ec);
    ::mkfifo((dir / "fifo").c_str(), 0600);

    const std::string all(reinterpret_cast<const char*>(data), size);
    struct Declared {
        char kind;
        fs::path path;
    };
    std::vector<Declared> accepted;
    {
        OutputFiles out;
        std::size_t at = 0;
        for (int line = 0; line < 8 && at < all.size(); ++line) {
            std::size_t end = all.find('\n', at);
            if (end == std::string::npos) end = all.size();
            const std::string l = all.substr(at, end - at);
            at = end + 1;
            if (l.empty() || l.find('\0') != std::string::npos) continue;
            fs::path rel;
            for (const auto& part : fs::path(l.substr(1)))
                if (part != ".." && part != "/" && !part.empty()) rel /= part;
            const fs::path p = dir / rel;
            const std::string given = p.string() + (l.size() > 1 && l.back() == '/' ? "/" : "");
            try {
                if (l[0] == 'i') {
                    out.addInput(given);
                    accepted.push_back({'i', p});
                } else if (l[0] == 'f') {
                    out.addFile("--f", given);
                    accepted.push_back({'f', p});
                } else if (l[0] == 'd') {
                    out.addFolder("--d", given, ".marker");
                    accepted.push_back({'d', p});
                }
            } catch (const SetupError&) {
            }
        }
        try {
            for (const Declared& d : accepted) {
                if (d.kind == 'f') out.writeText(d.path, "new");
                if (d.kind == 'd') put(out.stage(d.path) / "report.md", "report");
            }
            out.commit();
        } catch (const SetupError&) {
        } catch (const std::runtime_error&) {
        }
    }
    bool named = false, inputNamed = false;
    for (const Declared& d : accepted) {
        named = named || (d.kind == 'f' && d.path == dir / "plain" / "keep");
        inputNamed = inputNamed || (d.kind == 'f' && d.path == dir / "in" / "data.toml");
    }
    if (!named) require(get(dir / "plain" / "keep") == "user");
    if (!inputNamed) require(get(dir / "in" / "data.toml") == "input");
    for (const Declared& d : accepted)
        if (d.kind == 'd') require(fs::is_regular_file(fs::symlink_status(d.path / ".marker")));
    require(fs::is_fifo(fs::symlink_status(dir / "fifo")));
    require(fs::is_symlink(fs::symlink_status(dir / "loop")));
    // A temporary is "NAME.nvstim-XXXXXXXX.tmp"; an output may itself be named so.
    for (auto it = fs::recursive_directory_iterator(dir, ec);
         it != fs::recursive_directory_iterator(); it.increment(ec)) {
        if (ec) break;
        const std::string name = it->path().filename().string();
        const bool temporary = name.find(".nvstim-") != std::string::npos && name.size() > 4 &&
                               name.compare(name.size() - 4, 4, ".tmp") == 0;
        bool output = false;
        for (const Declared& d : accepted)
            output = output || (d.kind != 'i' && d.path == it->path());
        require(!temporary || output);
    }
    return 0;
}

int framePattern(const std::uint8_t* data, std::size_t size) {
    long long frame = 0;
    for (std::size_t i = 0; i < size && i < 8; ++i)
        frame = static_cast<long long>(static_cast<unsigned long long>(frame) << 8 | data[i]);
    const std::string pattern =
        text(data + std::min<std::size_t>(size, 8), size - std::min<std::size_t>(size, 8));
    const std::string name = io::expandFramePattern(pattern, frame);
    if (!io::hasFramePattern(pattern)) require(name == pattern);
    require(name.size() <= pattern.size() + 32);
    return 0;
}

}  // namespace nvs::fuzz
