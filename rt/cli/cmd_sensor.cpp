// nvstim sensor: push radiance images through a camera model: the IICCD chain (docs/design.md
// §4.5, §7), or, for a thermal preset (config/thermal_cameras), the uncooled microbolometer
// (docs/bolometer.md, "The command line").
//
//   nvstim sensor --in IN --camera PRESET [--set KEY=VALUE]... [--frames N] [--seed S]
//                 [--unit W/m2/sr|pe/s/m2/sr] [--spectrum flat|blackbody:T|moon|night_sky]
//                 --out OUT
//
// IN and OUT are a file or a pattern with {frame:06d}. A single input is held for N frames;
// a pattern gives one input per frame (N defaults to the run of existing files from 0).
// Every input is read and validated and every output path checked (sim/core/output_file.h)
// before anything is written; the outputs are written to temporaries and renamed into place
// together at the end, so an error or a signal never leaves a half-written file. Prints one JSON
// object with the per-field controls (gain_V, gate_s, level) on stdout.
//
// A thermal preset takes band radiance at the aperture in its band [W m⁻² sr⁻¹] (what `nvstim
// render` writes for a thermal scenario); .pgm/.png outputs are the 8-bit display (the preset's
// gain control), .exr the raw ADC counts. Before the first frame the core runs its start-up
// shutter correction facing a uniform scene: the radiance the render's header names
// (nvstim.startup_W_m2_sr, what `nvstim run` uses), else the first input's mean. A render made
// for another camera (a visible render, another band, another size) is refused.
//
// A render of nvstim's own names the camera preset it was made for (header nvstim.camera): a
// render for another preset than --camera is refused, naming both, unless --any-camera is given
// (the same preset by name, or the same file by path, is the same camera).
// Above a second of work a progress line goes to stderr once a second: frame N/TOTAL, the rate
// and the time left.

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "sim/bolometer/chain.h"
#include "sim/core/error.h"
#include "sim/core/input_file.h"
#include "sim/core/output_file.h"
#include "sim/io/exr.h"
#include "sim/io/frame_pattern.h"
#include "sim/io/image_file.h"
#include "sim/io/png.h"
#include "sim/io/pnm.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"

namespace nvs::cli {

namespace {

std::string lowerExt(const std::string& path) {
    std::string e = std::filesystem::path(path).extension().string();
    for (char& c : e)
        c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    return e;
}

// The attributes of nvstim's own renders that say which camera an image was made for.
struct RenderHeader {
    std::string camera, band;               // nvstim.camera, nvstim.band
    std::optional<double> startup_W_m2_sr;  // nvstim.startup_W_m2_sr (thermal renders)
};

// A preset as a file: a path as given, a name as config/cameras/NAME.toml or, failing that,
// config/thermal_cameras/NAME.toml.
std::filesystem::path presetFile(const std::filesystem::path& configDir,
                                 const std::string& preset) {
    if (preset.find('/') != std::string::npos || lowerExt(preset) == ".toml") return preset;
    const std::filesystem::path visible = configDir / "cameras" / (preset + ".toml");
    return nvs::pathExists(visible) ? visible : configDir / "thermal_cameras" / (preset + ".toml");
}

// Whether the preset a render names is --camera: the same name, or the same file.
bool samePreset(const std::filesystem::path& configDir, const std::string& rendered,
                const std::string& given) {
    if (rendered == given) return true;
    const std::filesystem::path a = presetFile(configDir, rendered),
                                b = presetFile(configDir, given);
    std::error_code ec;
    if (std::filesystem::exists(a, ec) && std::filesystem::exists(b, ec))
        return std::filesystem::equivalent(a, b, ec);
    return a.stem() == b.stem();  // a path not found here: its name decides
}

// A render for another preset than --camera is refused unless --any-camera: checked after the
// input's unit, band and size, which name the difference more closely where they differ.
void requireSameCamera(const std::string& file, const RenderHeader& h, const SensorOptions& opts,
                       const std::filesystem::path& configDir) {
    if (opts.anyCamera || h.camera.empty() || samePreset(configDir, h.camera, opts.camera)) return;
    throw SetupError(file + ": rendered for camera '" + h.camera + "', not --camera '" +
                     opts.camera + "' (render it with --camera, or give --any-camera to use it)");
}

// Reads a radiance image (.exr with its header, or .pfm) and its header into `header`; a
// thermal render (nvstim.band "LWIR ...") is refused unless `thermalCamera`.
io::RadianceFile readWithHeader(const std::string& file, const io::ImageLimits& limits,
                                RenderHeader& header, bool thermalCamera) {
    if (lowerExt(file) != ".exr") return io::readRadiance(file, limits);
    io::ExrImage exr = io::readExr(file, limits);
    RenderHeader h{exr.attribute("nvstim.camera"), exr.attribute("nvstim.band"), std::nullopt};
    if (!thermalCamera && h.band.rfind("LWIR", 0) == 0) {
        throw SetupError(file + ": a thermal render (camera '" + h.camera + "', band '" + h.band +
                         "'); an intensified camera takes visible radiance (give a thermal "
                         "preset as --camera)");
    }
    const std::string start = exr.attribute("nvstim.startup_W_m2_sr");
    if (!start.empty()) {
        char* end = nullptr;
        const double v = std::strtod(start.c_str(), &end);
        if (end == start.c_str() || *end != '\0' || !(v >= 0.0 && v < 1e30))
            throw SetupError(file + ": nvstim.startup_W_m2_sr '" + start + "' is not a radiance");
        h.startup_W_m2_sr = v;
    }
    header = h;
    return io::RadianceFile{std::move(exr.image), exr.attribute(io::kExrUnit),
                            exr.attribute(io::kExrSpectrum)};
}

// The first pixel that is not finite and ≥ 0 is an error naming it.
void requireValidRadiance(const std::string& file, const ImageF& img) {
    for (int y = 0; y < img.height(); ++y) {
        for (int x = 0; x < img.width(); ++x) {
            const float v = img(x, y);
            if (!(v >= 0.0f && v < 3.0e38f)) {
                throw SetupError(file + ": pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                                 ") is " + std::to_string(v) +
                                 "; radiance must be finite and >= 0 (" +
                                 std::to_string(sensor::IiccdChain::countBadPixels(img.cview())) +
                                 " bad pixels)");
            }
        }
    }
}

// Reads one input and turns it into Lpe [pe s⁻¹ m⁻² sr⁻¹], validating size and values.
ImageF loadInput(const std::string& file, const sensor::CameraParams& cam,
                 const SensorOptions& opts, const DataDirs& dirs) {
    // The header's size is checked before any pixel is allocated: up to a few thousand pixels a
    // side, so that a thermal render is named as such (its header) rather than by its size.
    io::ImageLimits limits;
    limits.maxWidth = std::max(cam.width, 4096);
    limits.maxHeight = std::max(cam.height, 4096);
    RenderHeader header;
    io::RadianceFile r = readWithHeader(file, limits, header, false);
    if (r.image.width() != cam.width || r.image.height() != cam.height) {
        throw SetupError(file + ": image is " + std::to_string(r.image.width()) + "x" +
                         std::to_string(r.image.height()) + ", camera '" + cam.name + "' expects " +
                         std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                         " (--set width=.. height=.. to change it)");
    }
    requireValidRadiance(file, r.image);
    const std::string unit = opts.unit ? *opts.unit : (r.unit.empty() ? "pe/s/m2/sr" : r.unit);
    if (unit == "W/m2/sr") {
        const std::string spectrum =
            opts.spectrum ? *opts.spectrum : (r.spectrum.empty() ? "flat" : r.spectrum);
        const float k =
            static_cast<float>(sensor::peRadiancePerBandRadiance(dirs.config, cam, spectrum));
        for (int y = 0; y < r.image.height(); ++y) {
            float* row = r.image.row(y);
            for (int x = 0; x < r.image.width(); ++x)
                row[x] *= k;
        }
    } else if (unit != "pe/s/m2/sr") {
        throw SetupError(file + ": unit '" + unit + "' is neither W/m2/sr nor pe/s/m2/sr");
    } else if (opts.spectrum) {
        throw SetupError("--spectrum applies only to --unit W/m2/sr inputs");
    }
    requireSameCamera(file, header, opts, dirs.config);
    return std::move(r.image);
}

// Writes the chain's last frame to the staged temporary of `file` (every write, flush and
// close checked by sim/io); OutputFiles renames it into place at the end.
void writeOutput(const std::string& file, const sensor::IiccdChain& chain, OutputFiles& outputs) {
    const std::string ext = lowerExt(file);
    const int maxv = (1 << chain.camera().adc_bits) - 1;
    outputs.writeWith(file, [&](const std::filesystem::path& tmp) {
        if (ext == ".pgm")
            io::writePgm(tmp, chain.video().cview(), maxv);
        else if (ext == ".png")
            io::writePng(tmp, chain.video().cview(), maxv);
        else
            io::writeExr(tmp, chain.counts().cview(), {{{io::kExrUnit, "DC"}}, {}, {}});
    });
}

// ---- Shared by both cameras.

// The progress line: once a second after the first, on stderr, frame N/TOTAL with the rate of
// the last second and the time left at that rate.
class Progress {
  public:
    explicit Progress(long long total) : total_(total) {}
    void frameDone(long long done) {
        const auto now = std::chrono::steady_clock::now();
        const double dt_s = std::chrono::duration<double>(now - last_).count();
        if (dt_s < 1.0) return;
        const double fps = static_cast<double>(done - lastDone_) / dt_s;
        std::fprintf(stderr, "nvstim sensor: frame %lld/%lld  %.2f fps", done, total_, fps);
        if (fps > 0.0) {
            std::fprintf(stderr, "  %.0f s left", static_cast<double>(total_ - done) / fps);
        }
        std::fprintf(stderr, "\n");
        last_ = now;
        lastDone_ = done;
    }

  private:
    long long total_, lastDone_ = 0;
    std::chrono::steady_clock::time_point last_ = std::chrono::steady_clock::now();
};

// Inputs: a pattern's run of existing files from 0, or --frames of one held input.
long long inputFrames(const SensorOptions& opts) {
    long long frames = opts.frames ? *opts.frames : 0;
    if (!opts.frames) {
        if (!io::hasFramePattern(opts.in))
            frames = 1;
        else
            while (nvs::pathExists(io::expandFramePattern(opts.in, frames)))
                ++frames;
    }
    if (frames <= 0) throw SetupError("--in " + opts.in + ": no input files (frame 0 missing)");
    return frames;
}

// Every output path checked against the inputs and each other; written at the end.
void addPaths(OutputFiles& outputs, const SensorOptions& opts, long long frames,
              const std::filesystem::path& preset) {
    outputs.addInput(preset);
    const bool inPattern = io::hasFramePattern(opts.in);
    const bool outPattern = io::hasFramePattern(opts.out);
    for (long long k = 0; k < (inPattern ? frames : 1); ++k)
        outputs.addInput(inPattern ? io::expandFramePattern(opts.in, k) : opts.in);
    for (long long k = 0; k < (outPattern ? frames : 1); ++k)
        outputs.addFile("--out", outPattern ? io::expandFramePattern(opts.out, k) : opts.out);
}

// ---- The thermal camera.

// One input of the thermal camera: band radiance at the aperture [W m⁻² sr⁻¹] in its band.
ImageF loadThermalInput(const std::string& file, const bolometer::ThermalCameraParams& cam,
                        RenderHeader& header, const SensorOptions& opts,
                        const std::filesystem::path& configDir) {
    // Read up to a few thousand pixels a side, so that a render for another camera is named as
    // such (its header) rather than by its size alone.
    io::ImageLimits limits;
    limits.maxWidth = std::max(cam.width, 4096);
    limits.maxHeight = std::max(cam.height, 4096);
    io::RadianceFile r = readWithHeader(file, limits, header, true);
    const std::string made =
        header.camera.empty() ? "" : " (rendered for camera '" + header.camera + "')";
    if (!r.unit.empty() && r.unit != "W/m2/sr") {
        throw SetupError(file + ": radiance in " + r.unit + made + "; thermal camera '" + cam.name +
                         "' takes band radiance in W/m2/sr (a thermal render)");
    }
    if (!header.band.empty() && header.band != bolometer::bandName(cam)) {
        throw SetupError(file + ": band '" + header.band + "'" + made + "; thermal camera '" +
                         cam.name + "' takes band '" + bolometer::bandName(cam) + "'");
    }
    if (r.image.width() != cam.width || r.image.height() != cam.height) {
        throw SetupError(file + ": image is " + std::to_string(r.image.width()) + "x" +
                         std::to_string(r.image.height()) + made + ", thermal camera '" + cam.name +
                         "' expects " + std::to_string(cam.width) + "x" +
                         std::to_string(cam.height));
    }
    requireValidRadiance(file, r.image);
    requireSameCamera(file, header, opts, configDir);
    return std::move(r.image);
}

void writeThermalOutput(const std::string& file, const bolometer::BolometerChain& chain,
                        OutputFiles& outputs) {
    const std::string ext = lowerExt(file);
    outputs.writeWith(file, [&](const std::filesystem::path& tmp) {
        if (ext == ".exr") {
            ImageF raw(chain.raw().width(), chain.raw().height());
            for (int y = 0; y < raw.height(); ++y)
                for (int x = 0; x < raw.width(); ++x)
                    raw(x, y) = chain.raw()(x, y);
            io::writeExr(tmp, raw.cview(), {{{io::kExrUnit, "DC"}}, {}, {}});
            return;
        }
        ImageU16 display(chain.display().width(), chain.display().height());
        for (int y = 0; y < display.height(); ++y)
            for (int x = 0; x < display.width(); ++x)
                display(x, y) = chain.display()(x, y);
        if (ext == ".pgm")
            io::writePgm(tmp, display.cview(), 255);
        else
            io::writePng(tmp, display.cview(), 255);
    });
}

std::string thermalJson(const bolometer::FrameInfo& f, bool first) {
    char buf[320];
    std::snprintf(buf, sizeof buf,
                  "%s{\"frame\":%llu,\"t_s\":%.6f,\"fpa_K\":%.4f,\"frozen\":%s,"
                  "\"shutter_closed\":%s,\"ffc_count\":%llu,\"mean_raw\":%.3f,"
                  "\"clipped_px\":%lld}",
                  first ? "" : ",", static_cast<unsigned long long>(f.frame), f.t_s, f.fpa_K,
                  f.frozen ? "true" : "false", f.shutter_closed ? "true" : "false",
                  static_cast<unsigned long long>(f.ffc_count), f.mean_raw,
                  static_cast<long long>(f.clipped_px));
    return buf;
}

int runThermalSensor(const SensorOptions& opts, const DataDirs& dirs,
                     const bolometer::Overrides& ov) {
    const bolometer::ThermalCameraParams cam =
        bolometer::loadThermalCamera(dirs.config, opts.camera, ov);
    if (opts.unit && *opts.unit != "W/m2/sr")
        throw SetupError("--unit " + *opts.unit + ": a thermal camera takes W/m2/sr");
    if (opts.spectrum) throw SetupError("--spectrum: not for a thermal camera");
    const long long frames = inputFrames(opts);
    const bool inPattern = io::hasFramePattern(opts.in);
    RenderHeader header;
    ImageF held;
    if (inPattern) {
        for (long long k = 0; k < frames; ++k) {
            RenderHeader h;
            (void)loadThermalInput(io::expandFramePattern(opts.in, k), cam, h, opts, dirs.config);
            if (k == 0) header = h;
        }
    } else {
        held = loadThermalInput(opts.in, cam, header, opts, dirs.config);
    }
    OutputFiles outputs;
    const std::filesystem::path preset =
        std::filesystem::path(opts.camera).extension() == ".toml"
            ? std::filesystem::path(opts.camera)
            : dirs.config / "thermal_cameras" / (opts.camera + ".toml");
    addPaths(outputs, opts, frames, preset);
    bolometer::BolometerChain chain(cam, opts.seed ? *opts.seed : 0, dirs.config);
    // The start-up shutter correction, as `nvstim run`'s camera (rt/camera_stage): the camera
    // powered up facing the scene, its first frames pictures, not frozen ones.
    double start = 0.0;
    if (header.startup_W_m2_sr) {
        start = *header.startup_W_m2_sr;
    } else {
        const ImageF first = inPattern ? loadThermalInput(io::expandFramePattern(opts.in, 0), cam,
                                                          header, opts, dirs.config)
                                       : held;
        for (int y = 0; y < first.height(); ++y)
            for (int x = 0; x < first.width(); ++x)
                start += static_cast<double>(first(x, y));
        start /= static_cast<double>(first.width()) * first.height();
    }
    {
        ImageF uniform(cam.width, cam.height);
        uniform.fill(static_cast<float>(start));
        for (int k = 0; k < 10000 && chain.process(uniform.cview()).frozen; ++k) {
        }
    }
    outputs.holdSignals();
    const bool outPattern = io::hasFramePattern(opts.out);
    Progress progress(frames);
    std::string json = "{\"camera\":\"" + cam.name + "\",\"band\":\"" + bolometer::bandName(cam) +
                       "\",\"frames\":" + std::to_string(frames) + ",\"frame_info\":[";
    for (long long k = 0; k < frames; ++k) {
        RenderHeader h;
        const ImageF in = inPattern ? loadThermalInput(io::expandFramePattern(opts.in, k), cam, h,
                                                       opts, dirs.config)
                                    : ImageF();
        const bolometer::FrameInfo& info = chain.process(inPattern ? in.cview() : held.cview());
        if (SignalHold::pending()) break;
        if (outPattern)
            writeThermalOutput(io::expandFramePattern(opts.out, k), chain, outputs);
        else if (k == frames - 1)
            writeThermalOutput(opts.out, chain, outputs);
        json += thermalJson(info, k == 0);
        progress.frameDone(k + 1);
    }
    json += "]}";
    outputs.commit();
    std::printf("%s\n", json.c_str());
    return kExitOk;
}

}  // namespace

int runSensor(const SensorOptions& opts) {
    // ---- Setup: camera, inputs, outputs; every check before anything is written.
    const DataDirs dirs = resolveDataDirs();
    const sensor::Overrides ov = sensor::parseOverrides(opts.sets);
    const std::string outExt = lowerExt(opts.out);
    if (outExt != ".pgm" && outExt != ".png" && outExt != ".exr") {
        throw SetupError("--out " + opts.out + ": output must be .pgm, .png or .exr");
    }
    if (bolometer::isThermalPreset(dirs.config, opts.camera))
        return runThermalSensor(opts, dirs, ov);
    const sensor::CameraParams cam = sensor::loadCamera(dirs.config, opts.camera, ov);
    const bool inPattern = io::hasFramePattern(opts.in);
    const long long frames = inputFrames(opts);
    if (opts.unit && *opts.unit != "W/m2/sr" && *opts.unit != "pe/s/m2/sr") {
        throw SetupError("--unit " + *opts.unit + ": expected W/m2/sr or pe/s/m2/sr");
    }
    if (opts.spectrum)
        (void)sensor::spectrumShape(dirs.config, *opts.spectrum);  // validates the spec
    ImageF held;
    if (inPattern) {
        for (long long k = 0; k < frames; ++k)
            (void)loadInput(io::expandFramePattern(opts.in, k), cam, opts, dirs);
    } else {
        held = loadInput(opts.in, cam, opts, dirs);
    }
    // Every output path checked now, against the inputs and each other; written at the end.
    OutputFiles outputs;
    addPaths(outputs, opts, frames, sensor::resolveCameraPath(dirs.config, opts.camera));
    const bool outPattern = io::hasFramePattern(opts.out);
    GammaTableCache gammaTables;
    sensor::IiccdChain chain(cam, opts.seed ? *opts.seed : 0, dirs.config, gammaTables);

    // ---- Run.
    outputs.holdSignals();  // a signal stops the run with no output and no temporary left
    Progress progress(frames);
    std::string json =
        "{\"camera\":\"" + cam.name + "\",\"frames\":" + std::to_string(frames) + ",\"fields\":[";
    for (long long k = 0; k < frames; ++k) {
        ImageF frameInput;
        if (inPattern) frameInput = loadInput(io::expandFramePattern(opts.in, k), cam, opts, dirs);
        const ImageF& in = inPattern ? frameInput : held;
        const sensor::FieldInfo& info = chain.process(in.cview());
        if (SignalHold::pending()) break;
        if (outPattern)
            writeOutput(io::expandFramePattern(opts.out, k), chain, outputs);
        else if (k == frames - 1)
            writeOutput(opts.out, chain, outputs);
        char buf[320];
        std::snprintf(buf, sizeof buf,
                      "%s{\"field\":%llu,\"t_sample_s\":%.6f,\"gain_V\":%.4f,\"mcp_gain\":%.5g,"
                      "\"gate_s\":%.6g,\"level_dc\":%.3f,\"mean_pe\":%.5g,\"saturated_px\":%lld}",
                      k == 0 ? "" : ",", static_cast<unsigned long long>(info.field),
                      info.t_sample_s, info.gain_V, info.mcp_gain, info.gate_s, info.level_dc,
                      info.mean_pe, static_cast<long long>(info.saturated_px));
        json += buf;
        progress.frameDone(k + 1);
    }
    json += "]}";
    outputs.commit();
    std::printf("%s\n", json.c_str());
    return kExitOk;
}

}  // namespace nvs::cli
