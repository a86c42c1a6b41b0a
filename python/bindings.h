#pragma once
// The Python module `nvstim` (docs/python.md): one function per part, each in its own file.
//   run.cpp       nvstim.Run, nvstim.Frame: a scenario's frames pulled (rt/session)
//   camera.cpp    nvstim.camera: the IICCD camera on a numpy radiance image (`nvstim sensor`)
//   diagnose.cpp  nvstim.diagnose: a dataset folder's findings (`nvstim diagnose --json`)

#include <pybind11/numpy.h>
#include <pybind11/pybind11.h>

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "sim/core/paths.h"
#include "sim/sensor/camera.h"

namespace nvs::py {

namespace pb = pybind11;

void bindRun(pb::module_& m);
void bindCamera(pb::module_& m);
void bindDiagnose(pb::module_& m);

// The data folders as `nvstim` resolves them (rt/cli/data_dirs.h), with the installed layout
// under the prefix the module was built for in place of the executable's folder; a given
// config_dir or cache_dir wins.
DataDirs moduleDataDirs(const std::optional<std::string>& configDir,
                        const std::optional<std::string>& cacheDir);

// `set={KEY: VALUE}` as `--set KEY=VALUE` arguments (sensor::parseOverrides, its checks and
// messages): text as it is, a bool as TOML writes it (true, false), a number as Python prints it.
sensor::Overrides presetOverrides(const pb::dict& sets);

// Counts the caller gives away as a C-contiguous numpy array of `shape` (no copy): the array's
// memory is the vector's, owned by a capsule that is the array's base and freed when the last
// array viewing it is collected. `bits` ≤ 8: uint8, the counts packed into the vector's first
// bytes in place (the y4m output's bytes); else uint16, as they are.
pb::array countsArray(std::vector<std::uint16_t>&& counts, const std::vector<pb::ssize_t>& shape,
                      int bits);

}  // namespace nvs::py
