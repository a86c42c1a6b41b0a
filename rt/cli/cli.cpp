#include "rt/cli/cli.h"

#include <CLI/CLI.hpp>
#include <charconv>
#include <cstdio>
#include <exception>
#include <optional>
#include <string>

#include "rt/cli/commands.h"
#include "sim/core/error.h"

namespace nvs::cli {

namespace {

// Largest frame number and frame count a command takes: the longest scenario (kMaxDuration_s,
// 10⁷ s) at the highest frame rate (10⁴ Hz).
constexpr unsigned long long kMaxFrames = 100'000'000'000ULL;
// Frames of `nvstim sensor` (each may be its own output file).
constexpr unsigned long long kMaxSensorFrames = 1'000'000ULL;

// A whole decimal integer in [lo, hi], digits only (no sign, space, exponent or fraction), or a
// SetupError naming the option: never a silent wrap or clamp.
unsigned long long parseInteger(const char* option, const std::string& text, unsigned long long lo,
                                unsigned long long hi) {
    unsigned long long v = 0;
    const char* end = text.data() + text.size();
    const auto [ptr, ec] = std::from_chars(text.data(), end, v);
    const bool digits = !text.empty() && text.find_first_not_of("0123456789") == std::string::npos;
    if (!digits || ec != std::errc() || ptr != end || v < lo || v > hi) {
        throw SetupError(std::string(option) + " " + text + ": must be a whole number in [" +
                         std::to_string(lo) + ", " + std::to_string(hi) + "]");
    }
    return v;
}

template <class T>
void parseInto(std::optional<T>& to, const char* option, const std::optional<std::string>& text,
               unsigned long long lo, unsigned long long hi) {
    if (text) to = static_cast<T>(parseInteger(option, *text, lo, hi));
}

}  // namespace

int runCli(int argc, const char* const* argv) {
    CLI::App app{
        "nvstim — real-time hardware-in-the-loop night-vision stimulator.\n"
        "Renders radiometrically correct night scenes for the time, site and pose it is given,\n"
        "passes them through a physical image-intensified CCD camera model, and emits video.",
        "nvstim"};
    app.set_version_flag("--version", std::string("nvstim ") + NVS_VERSION);
    app.require_subcommand(1);
    app.footer(
        "Exit status: 0 ok, 1 run failed, 2 usage or setup error (3 is reserved);\n"
        "`run` adds 4 when an output failed or had write errors and 8 when it was\n"
        "interrupted by SIGINT/SIGTERM (outputs closed cleanly): 4, 8 or 12.\n"
        "Run `nvstim SUBCOMMAND --help` for the options of one subcommand.");

    // run ------------------------------------------------------------------------------------
    RunOptions run;
    auto* runCmd = app.add_subcommand(
        "run", "Run a scenario: render, simulate the camera and emit video (HIL or replay).");
    runCmd->footer(
        "Exit status: 0 every frame run and every output worked; 1 the run failed (every output\n"
        "failed, sink_errors = \"stop\", bad telemetry under bad_input = \"stop\", --stats not\n"
        "written); 2 usage or setup error; else the sum of 4 (an output failed or had write\n"
        "errors, the others went on) and 8 (interrupted by SIGINT/SIGTERM; files closed and\n"
        "renamed into place).");
    runCmd->add_option("scenario", run.scenario, "Scenario TOML file or folder")->required();
    runCmd->add_option("--output", run.outputs,
                       "Output, repeatable: v4l2:/dev/videoN[?format=GREY|Y16|YUYV], y4m:PATH|-, "
                       "pgm:DIR, png:DIR, exr:DIR, meta:PATH|-, contact:FILE.png, "
                       "gpio:CHIP:LINE");
    runCmd
        ->add_option("--clock", run.clock,
                     "wall (real time, HIL) or sim (as fast as possible, "
                     "bit-exact)")
        ->check(CLI::IsMember({"wall", "sim"}))
        ->capture_default_str();
    std::optional<std::string> runFrames;
    runCmd->add_option("--frames", runFrames, "Stop after N frames (N >= 1)");
    runCmd->add_option(
        "--telemetry", run.telemetry,
        "Telemetry source: can:IFACE[?dbc=FILE], serial:DEV?baud=N&proto=nmea|mavlink, "
        "replay:FILE");
    runCmd->add_option("--stats", run.statsPath, "Write final statistics as JSON to FILE");
    runCmd->add_option(
        "--camera", run.camera,
        "Camera preset (name or .toml path) in place of the scenario's [camera] preset");
    runCmd->add_option(
        "--set", run.sets,
        "Override a camera preset key, KEY=VALUE (repeatable; wins over [camera] set)");
    runCmd
        ->add_option("--primary-visibility", run.primaryVisibility,
                     "Override [runtime] primary_visibility: embree, gl (OpenGL: a GPU through "
                     "EGL where there is one) or auto")
        ->check(CLI::IsMember({"embree", "gl", "auto"}));
    runCmd
        ->add_option("--render-threads", run.renderThreads,
                     "Override [runtime] render_threads (1..16)")
        ->check(CLI::Range(1, 16));
    runCmd
        ->add_option("--camera-threads", run.cameraThreads,
                     "Override [runtime] camera_threads (1..16; the same bits with any number)")
        ->check(CLI::Range(1, 16));

    // ephem ----------------------------------------------------------------------------------
    EphemOptions ephem;
    auto* ephemCmd = app.add_subcommand(
        "ephem", "Sun and Moon topocentric apparent position, distance and phase, as JSON.");
    ephemCmd->add_option("--lat", ephem.lat_deg, "Site latitude [deg, north positive]")
        ->required()
        ->check(CLI::Range(-90.0, 90.0));
    ephemCmd->add_option("--lon", ephem.lon_deg, "Site longitude [deg, east positive]")
        ->required()
        ->check(CLI::Range(-180.0, 360.0));
    ephemCmd->add_option("--height-m", ephem.height_m, "Site height above the ellipsoid [m]")
        ->capture_default_str();
    ephemCmd->add_option("--utc", ephem.utc, "UTC instant, ISO 8601 (2024-01-25T17:54:00Z)")
        ->required();
    ephemCmd->add_option("--pressure-hpa", ephem.pressure_hPa, "Pressure for refraction [hPa]")
        ->capture_default_str();
    ephemCmd->add_option("--temperature-c", ephem.temperature_C, "Temperature for refraction [°C]")
        ->capture_default_str();

    // illum ----------------------------------------------------------------------------------
    IllumOptions illum;
    auto* illumCmd = app.add_subcommand(
        "illum",
        "Illuminance on a horizontal surface from Moon, lunar sky and night sky, as JSON.");
    illumCmd->add_option("--lat", illum.lat_deg, "Site latitude [deg]")
        ->required()
        ->check(CLI::Range(-90.0, 90.0));
    illumCmd->add_option("--lon", illum.lon_deg, "Site longitude [deg, east positive]")
        ->required()
        ->check(CLI::Range(-180.0, 360.0));
    illumCmd->add_option("--height-m", illum.height_m, "Site height [m]")->capture_default_str();
    illumCmd->add_option("--utc", illum.utc, "UTC instant, ISO 8601")->required();
    illumCmd->add_option("--visibility-km", illum.visibility_km,
                         "Horizontal visibility (meteorological range at 550 nm) [km], default 23");
    illumCmd->add_option("--camera", illum.camera,
                         "Camera preset: also give photoelectron irradiance in its band and "
                         "the tube's gain");
    illumCmd->add_option("--gain-v", illum.gain_V,
                         "With --camera: the tube's gain at this control voltage [V] (default: "
                         "the preset's gain_V)");

    // render ---------------------------------------------------------------------------------
    RenderOptions render;
    auto* renderCmd = app.add_subcommand(
        "render", "Render one frame of a scenario to a photoelectron-radiance OpenEXR image.");
    renderCmd->add_option("scenario", render.scenario, "Scenario TOML file or folder")->required();
    std::optional<std::string> renderFrame;
    renderCmd->add_option("--frame", renderFrame, "Frame index K (>= 0)")->required();
    renderCmd->add_option("--out", render.out, "Output FILE.exr")->required();
    renderCmd->add_option("--camera", render.camera,
                          "Camera preset (name or .toml path) in place of the scenario's [camera] "
                          "preset");
    renderCmd->add_option("--set", render.sets,
                          "Override a camera preset key, KEY=VALUE (repeatable; wins over [camera] "
                          "set)");

    // sensor ---------------------------------------------------------------------------------
    SensorOptions sensor;
    auto* sensorCmd = app.add_subcommand(
        "sensor",
        "Push radiance images through a camera model (IICCD, or a thermal preset's "
        "microbolometer) to digital counts.");
    sensorCmd
        ->add_option("--in", sensor.in,
                     "Input file, or a pattern such as radiance/{frame:06d}.exr (EXR or PFM)")
        ->required();
    sensorCmd->add_option("--camera", sensor.camera, "Camera preset name or TOML path")->required();
    sensorCmd->add_option("--set", sensor.sets, "Override a preset key, KEY=VALUE (repeatable)");
    std::optional<std::string> sensorFrames, sensorSeed;
    sensorCmd->add_option("--frames", sensorFrames,
                          "Number of frames, 1..1000000 (a single input is held)");
    sensorCmd->add_option("--seed", sensorSeed, "Noise seed, 0..18446744073709551615");
    sensorCmd->add_option("--unit", sensor.unit, "Input unit: W/m2/sr or pe/s/m2/sr")
        ->check(CLI::IsMember({"W/m2/sr", "pe/s/m2/sr"}));
    sensorCmd->add_option("--spectrum", sensor.spectrum,
                          "Spectrum of a W/m2/sr input: flat, blackbody:T, moon, night_sky");
    sensorCmd->add_flag("--any-camera", sensor.anyCamera,
                        "Take a render whose header (nvstim.camera) names another camera preset");
    sensorCmd
        ->add_option("--out", sensor.out,
                     "Output file or pattern such as frames/{frame:06d}.pgm (PGM/PNG/EXR)")
        ->required();

    // replay ---------------------------------------------------------------------------------
    ReplayOptions replay;
    auto* replayCmd = app.add_subcommand(
        "replay", "Replay a recorded scenario deterministically; check or bless its expectations.");
    replayCmd->add_option("scenario_dir", replay.scenarioDir, "Scenario folder")->required();
    auto* checkFlag =
        replayCmd->add_flag("--check", replay.check, "Compare with the stored expectations");
    auto* blessFlag =
        replayCmd->add_flag("--bless", replay.bless, "Rewrite the stored expectations")
            ->excludes(checkFlag);
    replayCmd
        ->add_option("--out", replay.out,
                     "Keep the frames (DIR/frames/) and metadata (DIR/meta.jsonl) in DIR, a new or "
                     "empty folder (without it nothing is kept)")
        ->excludes(checkFlag)
        ->excludes(blessFlag);

    // list -----------------------------------------------------------------------------------
    ListOptions list;
    auto* listCmd = app.add_subcommand(
        "list", "List the camera presets or the scenarios this nvstim ships, one line each.");
    listCmd->add_option("what", list.what, "presets (or cameras) | scenarios")
        ->required()
        ->check(CLI::IsMember({"presets", "cameras", "scenarios"}));
    listCmd->add_flag("--json", list.json, "One JSON object per line instead of text");

    // sweep ----------------------------------------------------------------------------------
    SweepOptions sweep;
    auto* sweepCmd = app.add_subcommand(
        "sweep", "Run a grid of scenarios, presets, settings and seeds; one table of results.");
    sweepCmd->footer(
        "Exit status: 0 every job succeeded; 1 a job failed or left no result (recorded in the\n"
        "table), or sbatch failed; 2 usage or setup error (nothing written); 8 interrupted\n"
        "(finished jobs kept: the same command resumes). See docs/sweep.md.");
    sweepCmd->add_option("spec", sweep.spec, "Sweep spec (TOML): the grid and what a job runs");
    sweepCmd->add_option("--out", sweep.out,
                         "Output folder: new, empty, or a sweep of the same grid (resumed)");
    sweepCmd
        ->add_option("--jobs", sweep.jobs,
                     "Worker processes here (default 1); with --slurm the array's tasks at once")
        ->check(CLI::Range(1, 256));
    sweepCmd->add_option("--var", sweep.vars,
                         "Placeholder of a command spec, NAME=VALUE (repeatable)");
    sweepCmd->add_flag("--slurm", sweep.slurm, "Submit the jobs as one Slurm job array");
    sweepCmd->add_option("--sbatch-args", sweep.sbatchArgs,
                         "More sbatch options, e.g. \"-p short\"");
    sweepCmd->add_flag("--no-wait", sweep.noWait, "With --slurm: submit and return");
    sweepCmd->add_flag("--dry-run", sweep.dryRun, "Print the manifest (JSON lines); run nothing");
    std::optional<std::string> sweepTask;
    sweepCmd->add_option("--task", sweepTask, "Run job I of --manifest (an array task)");
    sweepCmd->add_option("--manifest", sweep.manifest, "The manifest of --task");
    sweepCmd->add_option("--gather", sweep.gather,
                         "Rebuild DIR's table and plots from its results");

    // diagnose -------------------------------------------------------------------------------
    DiagnoseOptions diagnose;
    auto* diagnoseCmd = app.add_subcommand(
        "diagnose", "Fit the camera model to a measured dataset and name what it gets wrong.");
    diagnoseCmd->add_option("dataset_dir", diagnose.datasetDir, "Dataset folder (dataset.toml)")
        ->required();
    diagnoseCmd->add_option("--json", diagnose.json, "Write the findings as JSON to OUT");
    diagnoseCmd->add_option("--report", diagnose.report,
                            "Write a report with plots to DIR (Markdown and PNG)");
    diagnoseCmd->add_option("--write-preset", diagnose.writePreset,
                            "Write the camera preset with the found effects on and fitted to FILE");
    diagnoseCmd
        ->add_option("--compare", diagnose.compare,
                     "Fit two presets (names or paths) on the calibration half and compare them "
                     "on the held-out half instead of diagnosing: RMS, likelihood, per region")
        ->expected(2)
        ->excludes("--write-preset");
    std::optional<std::string> diagnoseSeed;
    diagnoseCmd->add_option("--seed", diagnoseSeed,
                            "Seed of the model's noise, 0..18446744073709551615 (default 1)");

    // bench ----------------------------------------------------------------------------------
    BenchOptions bench;
    auto* benchCmd = app.add_subcommand("bench", "Run the performance benchmarks.");
    benchCmd->add_option("--json", bench.json, "Write results as JSON to OUT");
    benchCmd->add_option(
        "--filter", bench.filter,
        "Run only the benchmarks whose name contains TEXT, or any of comma-separated TEXTs "
        "(e.g. sensor_chain,eq71)");

    // CLI11 reports an unknown first word only as "a subcommand is required": name it instead.
    if (argc > 1 && argv[1][0] != '-') {
        bool known = false;
        for (const CLI::App* sub : app.get_subcommands({}))
            known = known || sub->get_name() == argv[1];
        if (!known) {
            std::fprintf(stderr, "nvstim: unknown subcommand '%s' (see --help)\n", argv[1]);
            return kExitUsage;
        }
    }
    try {
        app.parse(argc, argv);
    } catch (const CLI::ParseError& e) {
        if (e.get_exit_code() == 0) return app.exit(e) == 0 ? kExitOk : kExitUsage;  // --help
        // One line, naming the argument (CLI11's own exit() adds a second line).
        std::fprintf(stderr, "nvstim: %s (see --help)\n", e.what());
        return kExitUsage;
    }

    try {
        // Integers by hand: CLI11 wraps "-1" and 2^64 into an unsigned seed.
        constexpr unsigned long long kU64Max = ~0ULL;
        parseInto(run.frames, "--frames", runFrames, 1, kMaxFrames);
        std::optional<long long> frame;
        parseInto(frame, "--frame", renderFrame, 0, kMaxFrames);
        render.frame = frame.value_or(0);
        parseInto(sensor.frames, "--frames", sensorFrames, 1, kMaxSensorFrames);
        parseInto(sensor.seed, "--seed", sensorSeed, 0, kU64Max);
        std::optional<std::uint64_t> seed;
        parseInto(seed, "--seed", diagnoseSeed, 0, kU64Max);
        diagnose.seed = seed.value_or(diagnose.seed);
        parseInto(sweep.task, "--task", sweepTask, 0, 999999);
        if (*runCmd) return runRun(run);
        if (*ephemCmd) return runEphem(ephem);
        if (*illumCmd) return runIllum(illum);
        if (*renderCmd) return runRender(render);
        if (*sensorCmd) return runSensor(sensor);
        if (*replayCmd) return runReplay(replay);
        if (*diagnoseCmd) return runDiagnose(diagnose);
        if (*benchCmd) return runBench(bench);
        if (*listCmd) return runList(list);
        if (*sweepCmd) return runSweep(sweep);
    } catch (const SetupError& e) {
        std::fprintf(stderr, "nvstim: %s\n", e.what());
        return kExitUsage;
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nvstim: error: %s\n", e.what());
        return kExitFailure;
    }
    return kExitUsage;
}

}  // namespace nvs::cli
