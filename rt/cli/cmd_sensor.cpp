// nvstim sensor: push radiance images through the IICCD camera model (docs/design.md §4.5, §7).
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

#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
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

// Reads one input and turns it into Lpe [pe s⁻¹ m⁻² sr⁻¹], validating size and values.
ImageF loadInput(const std::string& file, const sensor::CameraParams& cam,
                 const SensorOptions& opts, const DataDirs& dirs) {
    // The header's size is checked against the camera's before any pixel is allocated.
    io::ImageLimits limits;
    limits.maxWidth = cam.width;
    limits.maxHeight = cam.height;
    io::RadianceFile r = io::readRadiance(file, limits);
    if (r.image.width() != cam.width || r.image.height() != cam.height) {
        throw SetupError(file + ": image is " + std::to_string(r.image.width()) + "x" +
                         std::to_string(r.image.height()) + ", camera '" + cam.name + "' expects " +
                         std::to_string(cam.width) + "x" + std::to_string(cam.height) +
                         " (--set width=.. height=.. to change it)");
    }
    for (int y = 0; y < r.image.height(); ++y) {
        for (int x = 0; x < r.image.width(); ++x) {
            const float v = r.image(x, y);
            if (!(v >= 0.0f && v < 3.0e38f)) {
                throw SetupError(
                    file + ": pixel (" + std::to_string(x) + ", " + std::to_string(y) + ") is " +
                    std::to_string(v) + "; radiance must be finite and >= 0 (" +
                    std::to_string(sensor::IiccdChain::countBadPixels(r.image.cview())) +
                    " bad pixels)");
            }
        }
    }
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

}  // namespace

int runSensor(const SensorOptions& opts) {
    // ---- Setup: camera, inputs, outputs; every check before anything is written.
    const DataDirs dirs = resolveDataDirs();
    const sensor::Overrides ov = sensor::parseOverrides(opts.sets);
    const sensor::CameraParams cam = sensor::loadCamera(dirs.config, opts.camera, ov);
    const std::string outExt = lowerExt(opts.out);
    if (outExt != ".pgm" && outExt != ".png" && outExt != ".exr") {
        throw SetupError("--out " + opts.out + ": output must be .pgm, .png or .exr");
    }
    const bool inPattern = io::hasFramePattern(opts.in);
    long long frames = opts.frames ? *opts.frames : 0;
    if (!opts.frames) {
        if (!inPattern)
            frames = 1;
        else
            while (nvs::pathExists(io::expandFramePattern(opts.in, frames)))
                ++frames;
    }
    if (frames <= 0) throw SetupError("--in " + opts.in + ": no input files (frame 0 missing)");
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
    outputs.addInput(sensor::resolveCameraPath(dirs.config, opts.camera));
    const bool outPattern = io::hasFramePattern(opts.out);
    for (long long k = 0; k < (inPattern ? frames : 1); ++k)
        outputs.addInput(inPattern ? io::expandFramePattern(opts.in, k) : opts.in);
    for (long long k = 0; k < (outPattern ? frames : 1); ++k)
        outputs.addFile("--out", outPattern ? io::expandFramePattern(opts.out, k) : opts.out);
    GammaTableCache gammaTables;
    sensor::IiccdChain chain(cam, opts.seed ? *opts.seed : 0, dirs.config, gammaTables);

    // ---- Run.
    outputs.holdSignals();  // a signal stops the run with no output and no temporary left
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
    }
    json += "]}";
    outputs.commit();
    std::printf("%s\n", json.c_str());
    return kExitOk;
}

}  // namespace nvs::cli
