// PYBIND11_MODULE(nvstim): the module's exception, its parts (bindings.h) and the one way a C++
// buffer becomes a numpy array.

#include <pybind11/stl.h>

#include <memory>

#include "python/bindings.h"
#include "sim/core/error.h"

namespace nvs::py {

sensor::Overrides presetOverrides(const pb::dict& sets) {
    std::vector<std::string> args;
    for (const auto& [key, value] : sets) {
        std::string v;
        if (pb::isinstance<pb::bool_>(value))
            v = value.cast<bool>() ? "true" : "false";
        else if (pb::isinstance<pb::str>(value))
            v = value.cast<std::string>();
        else
            v = pb::str(value).cast<std::string>();
        args.push_back(pb::str(key).cast<std::string>() + "=" + v);
    }
    return sensor::parseOverrides(args);
}

pb::array countsArray(std::vector<std::uint16_t>&& counts, const std::vector<pb::ssize_t>& shape,
                      int bits) {
    auto owned = std::make_unique<std::vector<std::uint16_t>>(std::move(counts));
    const std::size_t n = owned->size();
    // The vector's storage is a plain byte array to a char pointer (no aliasing rule broken):
    // byte i is written after element i / 2 ≤ i was read, so packing in place is safe.
    if (bits <= 8) {
        auto* bytes = reinterpret_cast<unsigned char*>(owned->data());
        for (std::size_t i = 0; i < n; ++i)
            bytes[i] = static_cast<unsigned char>((*owned)[i]);
    }
    void* data = owned->data();
    // The capsule owns the vector from here on (also if making the array throws).
    pb::capsule base(owned.get(),
                     [](void* p) { delete static_cast<std::vector<std::uint16_t>*>(p); });
    owned.release();
    if (bits <= 8) return pb::array_t<std::uint8_t>(shape, static_cast<std::uint8_t*>(data), base);
    return pb::array_t<std::uint16_t>(shape, static_cast<std::uint16_t*>(data), base);
}

}  // namespace nvs::py

PYBIND11_MODULE(nvstim, m) {
    namespace pb = pybind11;
    m.doc() =
        "nvstim: scenario runs with their frames as numpy arrays (Run), the camera model on a "
        "numpy radiance image (camera), diagnose on a measured dataset (diagnose). "
        "docs/python.md.";
    // The command line's setup error (status 2), with its one-line message.
    pb::register_exception<nvs::SetupError>(m, "SetupError", PyExc_ValueError);
    m.def(
        "data_dirs",
        [](const std::optional<std::string>& configDir,
           const std::optional<std::string>& cacheDir) {
            const nvs::DataDirs d = nvs::py::moduleDataDirs(configDir, cacheDir);
            pb::dict out;
            out["config"] = d.config.string();
            out["cache"] = d.cache.string();
            return out;
        },
        pb::kw_only(), pb::arg("config_dir") = pb::none(), pb::arg("cache_dir") = pb::none(),
        "The data folders the other functions use with these arguments: {'config': …, "
        "'cache': …} (docs/python.md, \"Building and installing\").");
    nvs::py::bindRun(m);
    nvs::py::bindCamera(m);
    nvs::py::bindDiagnose(m);
}
