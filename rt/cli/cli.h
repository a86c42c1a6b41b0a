#pragma once
// The `nvstim` command line (docs/design.md §7). Every subcommand is declared here with its
// options, parsed into a plain struct, and dispatched to its handler.
//
// Exit status: 0 success; 1 a run failed (a check mismatched, a device failed); 2 bad usage or
// setup error (one line on stderr naming the argument or file:line). 3 is reserved (it meant "not
// implemented yet"; every subcommand is implemented, none returns it).

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

namespace nvs::cli {

// `run` adds two bits that combine: kExitOutputFailed (an output failed, the run went on) and
// kExitInterrupted (stopped by SIGINT/SIGTERM, cleanly): 4, 8 or 12.
enum ExitCode : int {
    kExitOk = 0,
    kExitFailure = 1,
    kExitUsage = 2,
    kExitNotImplemented = 3,
    kExitOutputFailed = 4,
    kExitInterrupted = 8
};

struct RunOptions {
    std::string scenario;
    std::vector<std::string> outputs;  // v4l2:/dev/videoN[?format=..] | y4m:PATH|- | png:DIR | ...
    std::string clock = "wall";        // wall | sim
    std::optional<long long> frames;
    std::optional<std::string> telemetry;  // can:IFACE[?dbc=FILE] | serial:DEV?... | replay:FILE
    std::optional<std::string> statsPath;
    std::optional<std::string> primaryVisibility;  // embree | gl | auto: [runtime] overridden
    std::optional<int> renderThreads;              // 1..16: [runtime] render_threads overridden
    std::optional<int> cameraThreads;              // 1..16: [runtime] camera_threads overridden
    std::optional<std::string> camera;             // [camera] preset replaced
    std::vector<std::string> sets;                 // KEY=VALUE of the preset, over [camera] set
};

struct EphemOptions {
    double lat_deg = 0.0;
    double lon_deg = 0.0;
    double height_m = 0.0;
    std::string utc;
    double pressure_hPa = 1013.25;
    double temperature_C = 15.0;
};

struct IllumOptions {
    double lat_deg = 0.0;
    double lon_deg = 0.0;
    double height_m = 0.0;
    std::string utc;
    std::optional<double> visibility_km;
    std::optional<std::string> camera;
    std::optional<double> gain_V;  // tube gain control voltage for the camera's gain figures
};

struct RenderOptions {
    std::string scenario;
    long long frame = 0;
    std::string out;
    std::optional<std::string> camera;  // [camera] preset replaced, as run's --camera
    std::vector<std::string> sets;      // KEY=VALUE of the preset, as run's --set
};

struct SensorOptions {
    std::string in;
    std::string camera;
    std::vector<std::string> sets;  // KEY=VALUE
    std::optional<long long> frames;
    std::optional<unsigned long long> seed;
    std::string out;
    std::optional<std::string> unit;      // W/m2/sr | pe/s/m2/sr
    std::optional<std::string> spectrum;  // flat | blackbody:T | moon | night_sky
    bool anyCamera = false;               // take a render made for another camera
};

struct ReplayOptions {
    std::string scenarioDir;
    bool check = false;
    bool bless = false;
    std::optional<std::string> out;  // plain replay: keep the frames and metadata in this folder
};

struct SweepOptions {
    std::optional<std::string> spec;  // the sweep's TOML file
    std::optional<std::string> out;
    std::optional<int> jobs;        // local workers (1..256); with --slurm the array's %N
    std::vector<std::string> vars;  // NAME=VALUE
    bool slurm = false;
    std::optional<std::string> sbatchArgs;
    bool noWait = false;
    bool dryRun = false;
    std::optional<long long> task;  // with manifest: run one job
    std::optional<std::string> manifest;
    std::optional<std::string> gather;  // the table again from DIR's results
};

struct ListOptions {
    std::string what;  // presets | cameras (the same) | scenarios
    bool json = false;
};

struct DiagnoseOptions {
    std::string datasetDir;
    std::optional<std::string> json;
    std::optional<std::string> report;
    std::optional<std::string> writePreset;  // the preset with the found effects on
    std::uint64_t seed = 1;                  // the model's noise
    std::vector<std::string> compare;        // two presets: compare them instead of diagnosing
};

struct BenchOptions {
    std::optional<std::string> json;
    std::optional<std::string> filter;  // run only the benchmarks whose name contains this
};

// Parses argv and runs the chosen subcommand.
int runCli(int argc, const char* const* argv);

}  // namespace nvs::cli
