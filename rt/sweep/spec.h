#pragma once
// The sweep specification (docs/sweep.md): a TOML file naming a grid of scenarios, camera
// presets, preset settings and seeds, and what one job of the grid does. Strict TOML
// (sim/core/config.h): unknown keys are errors with file:line.
//
//   name        string            required; [A-Za-z0-9_.-]{1,64}
//   kind        "run" | "command" "run"
//   scenarios   array of strings  run: required. A name (thesis-full-moon: the shipped
//                                 scenarios folder, <config>/../scenarios/NAME) or a path
//                                 (holds '/' or ends in .toml) relative to the spec's folder
//   presets     array of strings  camera presets (`nvstim run --camera`): a name of
//                                 config/cameras, or a path relative to the spec's folder;
//                                 absent: each scenario's own
//   seeds       integer N or array of integers ≥ 0: N means 1..N; absent: the scenario's own
//   frames      integer ≥ 1       run: required (`nvstim run --frames`)
//   timeout_s   number > 0        a job still running after this long is stopped (3600)
//   keep_frames bool              run: keep each job's frames (PGM) after measuring (false)
//   run_args    array of strings  run: more options of `nvstim run` (e.g. "--render-threads",
//                                 "1"); not --frames, --clock, --camera, --set, --output, --stats
//   [set]       KEY = [values]    axes of the grid, in file order; run: each value a preset
//                                 key's (`nvstim run --set KEY=VALUE`); command: a placeholder
//   [vars]      KEY = value       fixed placeholders of the command (overridden by --var)
//   [command]   argv              command: array of strings, required; {placeholders} below
//               concat            a file each job writes into its folder ({job_dir}): the
//                                 jobs' files joined into the sweep's folder
//               concat_header_lines  the first file's first N lines once, then every file
//                                 without them (0)
//
// The grid is the product scenarios × presets × [set] (first key outermost) × seeds, the
// seed varying fastest; an absent axis is one empty value. Placeholders of a command:
// {index} {job_dir} {out} {spec_dir} {scenario} {preset} {seed}, each [set] key and each
// [vars] key; "{{" and "}}" are literal braces.

#include <cstdint>
#include <filesystem>
#include <map>
#include <optional>
#include <string>
#include <utility>
#include <vector>

namespace nvs::rt::sweep {

enum class JobKind { Run, Command };

struct SweepSpec {
    std::filesystem::path file;  // absolute
    std::string name;
    JobKind kind = JobKind::Run;
    // As written, and resolved (an absolute path, or a preset's name).
    std::vector<std::string> scenarios, scenarioPaths;
    std::vector<std::string> presets, presetArgs;
    std::vector<std::pair<std::string, std::vector<std::string>>> sets;  // file order
    std::vector<std::uint64_t> seeds;
    std::int64_t frames = 0;
    double timeout_s = 3600.0;
    bool keepFrames = false;
    std::vector<std::string> runArgs;
    std::vector<std::string> argv;  // the command's template
    std::map<std::string, std::string> vars;
    std::string concat;
    int concatHeaderLines = 0;
};

// Reads the spec; `vars` (--var NAME=VALUE) override its [vars]; scenario names are looked for
// in `scenariosDir`. Throws SetupError naming file:line or the option.
SweepSpec loadSpec(const std::filesystem::path& file, const std::filesystem::path& scenariosDir,
                   const std::vector<std::string>& vars);

// Replaces each {name} of `text` by its value; an unknown name or a lone brace is a
// SetupError naming `what`.
std::string expandPlaceholders(const std::string& text,
                               const std::map<std::string, std::string>& values,
                               const std::string& what);

}  // namespace nvs::rt::sweep
