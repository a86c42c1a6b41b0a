// nvstim.diagnose: a measured dataset folder diagnosed (rt/diagnose/diagnose_dataset.h, the path
// `nvstim diagnose` takes), its findings JSON parsed by Python's json module.

#include <pybind11/functional.h>
#include <pybind11/stl.h>

#include <memory>

#include "python/bindings.h"
#include "rt/diagnose/diagnose_dataset.h"

namespace nvs::py {

namespace {

pb::object diagnose(const std::string& datasetDir, std::uint64_t seed, const pb::object& progress,
                    const std::optional<std::string>& configDir,
                    const std::optional<std::string>& cacheDir) {
    const DataDirs dirs = moduleDataDirs(configDir, cacheDir);
    // Progress lines to the caller's function, with the GIL; the first exception it raises
    // stops the calls and is raised again when diagnose returns.
    std::unique_ptr<pb::error_already_set> raised;
    fit::Progress lines;
    if (!progress.is_none()) {
        lines = [&](const std::string& line) {
            pb::gil_scoped_acquire gil;
            if (raised) return;
            try {
                progress(line);
            } catch (pb::error_already_set& e) {
                raised = std::make_unique<pb::error_already_set>(std::move(e));
            }
        };
    }
    std::string json;
    {
        pb::gil_scoped_release nogil;
        json = rt::diagnoseDatasetJson(datasetDir, dirs, seed, lines);
    }
    if (raised) throw std::move(*raised);
    return pb::module_::import("json").attr("loads")(json);
}

}  // namespace

void bindDiagnose(pb::module_& m) {
    m.def("diagnose", &diagnose, pb::arg("dataset_dir"), pb::kw_only(), pb::arg("seed") = 1,
          pb::arg("progress") = pb::none(), pb::arg("config_dir") = pb::none(),
          pb::arg("cache_dir") = pb::none(),
          "Fits the camera model to a measured dataset folder and names what it gets wrong: "
          "the findings as `nvstim diagnose DATASET --json OUT` writes them, parsed (a dict). "
          "progress: a function called with each progress line (none by default).");
}

}  // namespace nvs::py
