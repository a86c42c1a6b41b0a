// nvstim.camera: the IICCD camera model on a numpy radiance image, as `nvstim sensor --in IN
// --camera PRESET --out F.pgm` runs it (rt/cli/cmd_sensor.cpp): the same preset and overrides,
// unit conversion, seed and chain, one call of the model per frame; the frames' counts (what
// the PGM output holds) as one numpy array.

#include "sim/bolometer/camera.h"

#include <pybind11/stl.h>

#include <cstring>

#include "python/bindings.h"
#include "sim/core/error.h"
#include "sim/core/gamma_table.h"
#include "sim/core/image.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"

namespace nvs::py {

namespace {

using Radiance = pb::array_t<float, pb::array::c_style | pb::array::forcecast>;

// Image k of the input (k < its count) as Lpe [pe s⁻¹ m⁻² sr⁻¹], validated as `nvstim
// sensor` validates a file: the camera's size, every pixel finite and ≥ 0; W/m2/sr scaled by
// the same single-precision factor.
ImageF loadImage(const Radiance& in, pb::ssize_t k, const sensor::CameraParams& cam, float k_pe) {
    const int h = static_cast<int>(in.shape(in.ndim() - 2));
    const int w = static_cast<int>(in.shape(in.ndim() - 1));
    if (w != cam.width || h != cam.height) {
        throw SetupError("radiance: image is " + std::to_string(w) + "x" + std::to_string(h) +
                         ", camera '" + cam.name + "' expects " + std::to_string(cam.width) + "x" +
                         std::to_string(cam.height) +
                         " (set={'width': .., 'height': ..} to change it)");
    }
    ImageF img(w, h);
    const float* src = in.data() + static_cast<std::size_t>(k) * static_cast<std::size_t>(w) * h;
    for (int y = 0; y < h; ++y)
        std::memcpy(img.row(y), src + static_cast<std::size_t>(y) * w, sizeof(float) * w);
    for (int y = 0; y < h; ++y) {
        for (int x = 0; x < w; ++x) {
            const float v = img(x, y);
            if (!(v >= 0.0f && v < 3.0e38f)) {
                throw SetupError(
                    "radiance: pixel (" + std::to_string(x) + ", " + std::to_string(y) +
                    (in.ndim() == 3 ? " of image " + std::to_string(k) : "") + ") is " +
                    std::to_string(v) + "; radiance must be finite and >= 0 (" +
                    std::to_string(sensor::IiccdChain::countBadPixels(img.cview())) +
                    " bad pixels)");
            }
        }
    }
    if (k_pe != 1.0f) {
        for (int y = 0; y < h; ++y) {
            float* row = img.row(y);
            for (int x = 0; x < w; ++x)
                row[x] *= k_pe;
        }
    }
    return img;
}

pb::array camera(const Radiance& radiance, const std::string& preset, const pb::dict& sets,
                 std::optional<std::int64_t> frames, std::uint64_t seed, const std::string& unit,
                 const std::optional<std::string>& spectrum,
                 const std::optional<std::string>& configDir) {
    const DataDirs dirs = moduleDataDirs(configDir, std::nullopt);
    const sensor::Overrides ov = presetOverrides(sets);
    if (bolometer::isThermalPreset(dirs.config, preset)) {
        throw SetupError("camera '" + preset +
                         "': a thermal preset; nvstim.camera runs the intensified camera "
                         "(`nvstim sensor` runs both)");
    }
    const sensor::CameraParams cam = sensor::loadCamera(dirs.config, preset, ov);
    // Inputs: one image held for `frames` frames, or one image per frame.
    if (radiance.ndim() != 2 && radiance.ndim() != 3)
        throw SetupError("radiance: a (height, width) or (frames, height, width) array");
    const pb::ssize_t images = radiance.ndim() == 3 ? radiance.shape(0) : 1;
    if (radiance.ndim() == 3 && frames && *frames != images) {
        throw SetupError("frames " + std::to_string(*frames) + ": the radiance holds " +
                         std::to_string(images) + " images (one per frame)");
    }
    const std::int64_t n = radiance.ndim() == 3 ? images : frames.value_or(1);
    if (n < 1) throw SetupError("frames must be >= 1");
    float k_pe = 1.0f;
    if (unit == "W/m2/sr") {
        k_pe = static_cast<float>(
            sensor::peRadiancePerBandRadiance(dirs.config, cam, spectrum.value_or("flat")));
    } else if (unit != "pe/s/m2/sr") {
        throw SetupError("unit '" + unit + "': expected W/m2/sr or pe/s/m2/sr");
    } else if (spectrum) {
        throw SetupError("spectrum applies only to unit W/m2/sr radiance");
    }
    std::vector<ImageF> inputs;
    for (pb::ssize_t k = 0; k < images; ++k)
        inputs.push_back(loadImage(radiance, k, cam, k_pe));

    const std::size_t px =
        static_cast<std::size_t>(cam.width) * static_cast<std::size_t>(cam.height);
    std::vector<std::uint16_t> out(px * static_cast<std::size_t>(n));
    {
        pb::gil_scoped_release nogil;
        GammaTableCache gammaTables;
        sensor::IiccdChain chain(cam, seed, dirs.config, gammaTables);
        for (std::int64_t k = 0; k < n; ++k) {
            (void)chain.process(inputs[static_cast<std::size_t>(images == 1 ? 0 : k)].cview());
            // The output frame's counts, as the PGM and PNG outputs write them.
            std::uint16_t* dst = out.data() + px * static_cast<std::size_t>(k);
            for (int y = 0; y < cam.height; ++y)
                std::memcpy(dst + static_cast<std::size_t>(y) * cam.width, chain.video().row(y),
                            sizeof(std::uint16_t) * static_cast<std::size_t>(cam.width));
        }
    }
    return countsArray(std::move(out), {static_cast<pb::ssize_t>(n), cam.height, cam.width},
                       cam.adc_bits);
}

}  // namespace

void bindCamera(pb::module_& m) {
    m.def("camera", &camera, pb::arg("radiance"), pb::arg("preset"), pb::kw_only(),
          pb::arg("set") = pb::dict(), pb::arg("frames") = pb::none(), pb::arg("seed") = 0,
          pb::arg("unit") = "pe/s/m2/sr", pb::arg("spectrum") = pb::none(),
          pb::arg("config_dir") = pb::none(),
          "The IICCD camera on a radiance image: (frames, height, width) counts, uint8 for an "
          "ADC of at most 8 bits, else uint16 (what `nvstim sensor --out F.pgm` writes). "
          "radiance: (height, width), held for `frames` frames (default 1), or (frames, height, "
          "width), one image per frame.");
}

}  // namespace nvs::py
