// nvstim bench [--json OUT] [--filter TEXT]: times each stage of a frame on this machine against
// the budgets the issues set, the plain references the ratios are stated against, and the frame
// loop end to end; prints one JSON object on stdout (progress and a table on stderr) and writes
// it to OUT (docs/contracts.md, "bench"; docs/performance.md for figures measured with it).
//
//   end to end      scenarios/airborne-pass (768×494 interlaced, moving platform, every camera
//                   stage) and scenarios/airborne-pass-sxga (1280×1024 progressive) through
//                   rt/run under the sim clock (rt/bench/end_to_end.h): fields/s, field period,
//                   peak RSS, operator new calls per field in steady state
//   stages          Google Benchmark items (rt/bench/timed_items.h): ephemeris, sky lookup,
//                   render (RIT stlamp, full and coarse f = 4, 1 and 2 threads, fixed and moving
//                   camera; the vehicle-drive truck), the camera chain (one field); the
//                   airborne pass flown along its log (a field at 768×494; 1280×1024 full rate,
//                   coarse, its primary pass alone, and its camera chain)
//   references      Embree's own single-ray and 16-packet rates on the render's primary rays,
//                   the plain eq. 7.1 model (rt/bench/eq71_reference.h) on the camera chain's
//                   frames, a frame-sized memcpy
//   ratios          renderer rays/s over Embree's single-ray rate, eq. 7.1 reference time over
//                   chain time, chain time over the memcpy

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "rt/bench/end_to_end.h"
#include "rt/bench/eq71_reference.h"
#include "rt/bench/timed_items.h"
#include "rt/cli/commands.h"
#include "rt/cli/data_dirs.h"
#include "rt/compose/platform_pose.h"
#include "rt/compose/scene_setup.h"
#include "rt/compose/thermal_scene.h"
#include "rt/render_stage/row_pool.h"
#include "rt/run/run.h"
#include "rt/run/telemetry_factory.h"
#include "sim/astro/ephemeris.h"
#include "sim/bolometer/chain.h"
#include "sim/core/error.h"
#include "sim/core/output_file.h"
#include "sim/core/units.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/chain.h"
#include "sim/sky/night_sky.h"
#include "sim/sky/sky_model.h"

namespace nvs::cli {
namespace {

using rt::bench::threadCpu_s;
using rt::bench::TimedItem;
using Items = std::vector<std::unique_ptr<TimedItem>>;

// Every core of the machine, at most 16 (the renderer's and the camera's thread limit).
int coresUpTo16() {
    return std::clamp(static_cast<int>(std::thread::hardware_concurrency()), 1, 16);
}

TimedItem& add(Items& items, std::string name, std::string what, std::optional<double> target_s,
               double minTime_s) {
    items.push_back(std::make_unique<TimedItem>());
    TimedItem& it = *items.back();
    it.name = std::move(name);
    it.what = std::move(what);
    it.target_s = target_s;
    it.minTime_s = minTime_s;
    return it;
}

// Ephemeris and sources for one frame; the sky terms for one Moon geometry.
void addAstroSkyItems(Items& items, const DataDirs& dirs) {
    struct Astro {
        std::unique_ptr<astro::Ephemeris> eph;
        astro::AstroTime t0;
        std::unique_ptr<sky::MoonSource> moon;
        std::unique_ptr<sky::NightSkyModel> night;
        Spectrum m, n;
        long long k = 0;
    };
    auto a = std::make_shared<Astro>();
    TimedItem& e = add(items, "ephemeris_sources", "Sun/Moon position, lunar and night-sky spectra",
                       50e-6, 1.0);
    e.setup = [a, dirs] {
        astro::Site site;
        site.lat_deg = 43.16856;
        site.lon_deg = -77.61583;
        site.height_m = 218.0;
        a->eph = std::make_unique<astro::Ephemeris>(site);
        a->t0 = astro::astroTimeFromUtc(astro::parseIsoUtc("1998-09-02T01:00Z"));
        a->moon = std::make_unique<sky::MoonSource>(sky::MoonSource::load(dirs.config));
        a->night = std::make_unique<sky::NightSkyModel>(sky::NightSkyModel::load(dirs.config));
    };
    e.iteration = [a] {
        const auto s = a->eph->compute(a->t0.plusSeconds(static_cast<double>(a->k++) / 30.0));
        a->moon->spectralIrradianceToa(s.moon, a->m);
        a->night->radiance(sky::NightSkyScales{}, a->n);
    };
    struct Sky {
        std::unique_ptr<sky::SkyModel> model;
        astro::MoonState moon;
        double z = 0.1, sink = 0.0;
    };
    auto s = std::make_shared<Sky>();
    TimedItem& k = add(items, "sky_lookup", "horizontal terms, sky radiance, night sky, path terms",
                       20e-6, 1.0);
    k.setup = [s, dirs] {
        s->model =
            std::make_unique<sky::SkyModel>(sky::SkyModel::create(sky::SkyModelConfig{}, dirs));
        s->moon.alt_rad = 0.6;
        s->moon.phaseAngle_rad = 0.3;
        s->moon.distanceTopocentric_m = sky::kMoonMeanDistance_m;
        s->moon.sunDistance_m = 1.496e11;
    };
    k.iteration = [s] {
        s->z = s->z > 1.4 ? 0.1 : s->z + 1e-3;
        const auto h = s->model->horizontal(0, s->moon);
        const auto p = s->model->table().path(0, 300.0, 2.0, 500.0, 0.3, 0.97);
        s->sink += h.total + p.transmittance + s->model->table().skyRadiance(0, s->z, 1.0, 0.97) +
                   s->model->table().nightSkyRadiance(0, s->z);
    };
}

// A scenario's renderer and its images, created by the first item that needs it.
struct SharedRender {
    std::filesystem::path file;
    DataDirs dirs;
    int coarse = 1;
    std::unique_ptr<rt::ScenarioRenderer> sr;
    ImageF pe, band;
    rt::ScenarioRenderer& get() {
        if (!sr) {
            sr = rt::ScenarioRenderer::create(file, dirs, coarse);
            pe = ImageF(sr->scenario().width, sr->scenario().height);
            band = ImageF(pe.width(), pe.height());
        }
        return *sr;
    }
};

// Rays the last render cast, per second of the item's median time.
void addRayRate(TimedItem& it, const render::Renderer& r) {
    const double rays = static_cast<double>(r.lastStats().total());
    it.extra.emplace_back("rays_per_frame", rays);
    it.extra.emplace_back("rays_per_s", rays / it.p50_s);
}

// The RIT scene ("stlamp": Moon shadows, the street lamp in its apertured housing, specular
// asphalt), full rate and with coarse lighting tiles (f = 4), on 1 and 2 threads (the calling
// thread plus a RowPool worker), with the scenario's fixed camera (the G-buffer is reused) and
// with the camera set again every frame (a moving platform: primary rays and static lighting
// data every frame). Targets (issue: full rate ≤ 30 ms, coarse ≤ 8 ms on this 2-core machine).
// Then Embree's own single-ray and 16-packet rates on the same primary rays.
void addRenderItems(Items& items, const DataDirs& dirs, const std::filesystem::path& rit) {
    for (const int coarse : {1, 4}) {
        auto shared = std::make_shared<SharedRender>();
        shared->file = rit;
        shared->dirs = dirs;
        shared->coarse = coarse;
        const std::string base = coarse == 1 ? "render_full" : "render_coarse4";
        for (const int threads : {1, 2}) {
            auto pool = std::make_shared<std::unique_ptr<rt::RowPool>>();
            for (const bool moving : {false, true}) {
                const std::string name =
                    base + "_" + std::to_string(threads) + "t" + (moving ? "_moving" : "");
                const std::string what = "RIT stlamp 768x494, " + std::to_string(threads) +
                                         (threads == 1 ? " thread, " : " threads, ") +
                                         (moving ? "camera moving (primary rays every frame)"
                                                 : "fixed camera (G-buffer reused)");
                TimedItem& it = add(items, name, what, coarse == 1 ? 30e-3 : 8e-3, 1.5);
                it.setup = [shared, pool, threads] {
                    shared->get();
                    if (!*pool) *pool = std::make_unique<rt::RowPool>(threads);
                };
                it.iteration = [shared, pool, moving] {
                    rt::ScenarioRenderer& sr = *shared->sr;
                    if (moving) sr.renderer().setCamera(sr.scene().camera);
                    sr.renderFrame(0.0, shared->pe.view(), shared->band.view(), **pool);
                };
                it.after = [shared](TimedItem& self) { addRayRate(self, shared->sr->renderer()); };
            }
        }
        if (coarse != 1) continue;
        // Embree alone: one pass of primary rays through every pixel centre of the same view.
        for (const bool packets : {false, true}) {
            TimedItem& it = add(
                items, packets ? "embree_packet16_primary" : "embree_single_primary",
                packets ? "Embree rtcIntersect16, coherent 4x4 packets, RIT stlamp primary rays, "
                          "1 thread"
                        : "Embree rtcIntersect1, RIT stlamp primary rays, 1 thread",
                std::nullopt, 1.0);
            it.setup = [shared] { shared->get(); };
            it.iteration = [shared, packets] {
                (void)shared->sr->renderer().tracePrimaryRays(packets);  // timed by the item
            };
            it.after = [shared](TimedItem& self) {
                const double rays = static_cast<double>(shared->pe.width()) * shared->pe.height();
                self.extra.emplace_back("rays_per_frame", rays);
                self.extra.emplace_back("rays_per_s", rays / self.p50_s);
            };
        }
    }
}

// A truck crossing the lot under the fixed camera (scenarios/vehicle-drive): each frame moves it
// on by 1/29.97 s (the first 2 s of its trajectory, over and over), so only the pixels and rays
// it touches are redone.
void addTruckItems(Items& items, const DataDirs& dirs, const std::filesystem::path& drive) {
    for (const int coarse : {1, 4}) {
        auto shared = std::make_shared<SharedRender>();
        shared->file = drive;
        shared->dirs = dirs;
        shared->coarse = coarse;
        auto pool = std::make_shared<std::unique_ptr<rt::RowPool>>();
        auto k = std::make_shared<int>(0);
        TimedItem& it =
            add(items, std::string(coarse == 1 ? "render_full" : "render_coarse4") + "_2t_truck",
                "RIT vehicle-drive, 2 threads, truck moving under the fixed camera",
                coarse == 1 ? 30e-3 : 8e-3, 1.5);
        it.setup = [shared, pool] {
            shared->get();
            *pool = std::make_unique<rt::RowPool>(2);
        };
        it.iteration = [shared, pool, k] {
            shared->sr->renderFrame((*k)++ % 60 / 29.97, shared->pe.view(), shared->band.view(),
                                    **pool);
        };
        it.after = [shared](TimedItem& self) { addRayRate(self, shared->sr->renderer()); };
    }
}

// The airborne pass over its scene, the camera moving along the flight log as `nvstim run` moves
// it: the scenario's [telemetry] replay through the runtime's telemetry source, sampled a field
// (768×494 interlaced, scenarios/airborne-pass) or a frame (1280×1024 progressive,
// airborne-pass-sxga) apart over the log's first 2 s, and placed by PlatformPose. Each iteration
// takes the next pose (the poses are sampled at setup; the track is not run backwards). On two
// threads: a field's own rows at 768×494; every row at 1280×1024, full rate and coarse f = 4,
// and its primary pass alone (Embree's packets: the geometry buffer, rebuilt each frame under a
// moving camera); then the SXGA camera's chain, one frame on one thread (the runtime's camera
// thread), on the first pose's render. What a progressive 1280×1024 frame costs where its time
// goes: docs/performance.md.
struct Flight {
    std::filesystem::path file;
    DataDirs dirs;
    int coarse = 1;
    double period_s = 1.0 / 30.0;  // between poses
    // Overrides of the scenario: image size (0: the scenario's; the field of view is kept),
    // primary visibility, threads.
    int width = 0, height = 0;
    std::optional<render::PrimaryVisibility> visibility;
    int threads = 2;
    std::function<void(rt::Scenario&)> adjust;  // edits the loaded scenario (thermal items)
    std::unique_ptr<rt::ScenarioRenderer> sr;
    std::vector<scene::CameraPose> poses;
    std::size_t next = 0;
    ImageF pe, band;
    std::unique_ptr<rt::RowPool> pool;
    rt::ScenarioRenderer& get() {
        if (sr) return *sr;
        rt::Scenario loaded = rt::loadScenario(file, dirs.config);
        if (width > 0) loaded.width = width;
        if (height > 0) loaded.height = height;
        if (visibility) loaded.primaryVisibility = *visibility;
        if (adjust) adjust(loaded);
        sr = rt::ScenarioRenderer::create(loaded, dirs, coarse);
        const rt::Scenario& sc = sr->scenario();
        if (!sc.telemetry) throw SetupError(file.string() + ": no [telemetry] to fly");
        rt::Spec spec = rt::parseSpec(*sc.telemetry, "[telemetry] source");
        const std::unique_ptr<rt::PlatformSource> src = rt::makeTelemetrySource(
            spec, sc, rt::ClockKind::Sim, "[telemetry] source", dirs.config);
        const rt::PlatformPose place(sc.scene.site);
        for (double t = 0.0; t < 2.0; t += period_s) {
            msg::PlatformState st = sc.platform;
            src->sample(t, t, st);
            poses.push_back(place.poseFor(st));
        }
        pe = ImageF(sc.width, sc.height);
        band = ImageF(sc.width, sc.height);
        pool = std::make_unique<rt::RowPool>(threads);
        return *sr;
    }
    // Renders the next pose's frame, or its field of parity `rowParity` (-1: every row).
    void renderNext(int rowParity) {
        const std::size_t k = next++ % poses.size();
        sr->renderer().setCamera(poses[k]);
        sr->renderFrame(static_cast<double>(k) * period_s, pe.view(), band.view(), *pool,
                        rowParity);
    }
};

void addAirborneItems(Items& items, const DataDirs& dirs, const std::filesystem::path& scenarios) {
    const std::filesystem::path air = scenarios / "airborne-pass" / "scenario.toml";
    const std::filesystem::path sxga = scenarios / "airborne-pass-sxga" / "scenario.toml";
    auto flight = [&dirs](const std::filesystem::path& file, int coarse, double period_s) {
        auto f = std::make_shared<Flight>();
        f->file = file;
        f->dirs = dirs;
        f->coarse = coarse;
        f->period_s = period_s;
        return f;
    };
    if (std::filesystem::exists(air)) {
        auto f = flight(air, 1, 1001.0 / 60000.0);
        TimedItem& it = add(items, "render_air_field_2t",
                            "airborne pass 768x494 interlaced, 2 threads, one field's rows, camera "
                            "moving along the flight log",
                            std::nullopt, 1.5);
        it.setup = [f] { f->get(); };
        it.iteration = [f] { f->renderNext(static_cast<int>(f->next % 2)); };
        it.after = [f](TimedItem& self) { addRayRate(self, f->sr->renderer()); };
    }
    if (!std::filesystem::exists(sxga)) return;
    for (const int coarse : {1, 4}) {
        auto f = flight(sxga, coarse, 1.0 / 30.0);
        TimedItem& it =
            add(items, coarse == 1 ? "render_air_sxga_full_2t" : "render_air_sxga_coarse4_2t",
                std::string("airborne pass 1280x1024 progressive, 2 threads, ") +
                    (coarse == 1 ? "full rate" : "coarse f = 4") +
                    ", camera moving along the flight log",
                std::nullopt, 1.5);
        it.setup = [f] { f->get(); };
        it.iteration = [f] { f->renderNext(-1); };
        it.after = [f](TimedItem& self) { addRayRate(self, f->sr->renderer()); };
        if (coarse != 1) continue;
        TimedItem& p = add(items, "primary_air_sxga_2t",
                           "airborne pass 1280x1024, 2 threads, the primary pass alone (Embree "
                           "packets: the whole geometry buffer), camera moving",
                           std::nullopt, 1.5);
        p.setup = [f] { f->get(); };
        p.iteration = [f] {
            // Zero repetitions: the one untimed pass of measurePrimaryPasses, timed here.
            f->sr->renderer().setCamera(f->poses[f->next++ % f->poses.size()]);
            (void)f->sr->renderer().measurePrimaryPasses(*f->pool, 0);
        };
        struct Chain {
            GammaTableCache gammaTables;
            std::unique_ptr<sensor::IiccdChain> chain;
        };
        auto c = std::make_shared<Chain>();
        TimedItem& ch = add(items, "sensor_chain_air_sxga",
                            "IICCD chain of airborne-pass-sxga, one 1280x1024 frame, one thread, "
                            "the flight's first frame",
                            std::nullopt, 2.0);
        ch.setup = [f, c] {
            f->get();
            if (c->chain) return;
            f->next = 0;
            f->renderNext(-1);
            // The camera as the runtime's camera stage makes it: the scenario's (its size).
            const rt::Scenario& sc = f->sr->scenario();
            c->chain = std::make_unique<sensor::IiccdChain>(sc.camera.params, sc.camera.seed,
                                                            f->dirs.config, c->gammaTables);
        };
        ch.iteration = [f, c] { c->chain->process(f->pe.cview()); };
        ch.after = [f, c](TimedItem& self) {
            self.extra.emplace_back("mean_pe_per_px", c->chain->process(f->pe.cview()).mean_pe);
        };
    }
}

// Primary visibility at 1920×1080 (docs/performance.md, "Primary visibility on a GPU"): the
// airborne pass's scene and field of view drawn at 1920 × 1080, the camera moving along the
// flight log a frame apart, the whole geometry buffer each iteration, on every core of the
// machine (at most 16, the renderer's limit). By OpenGL (the first backend that works: a GPU
// through EGL where there is one, else Mesa's llvmpipe) against a 120 frames/s budget, and by
// Embree's packets for comparison. After timing, the GL item splits its time into the draw and
// read-back and the G-buffer the CPU builds from the hits (20 passes on the last pose) and
// names the renderer in its note.
void addPrimary1080Items(Items& items, const DataDirs& dirs,
                         const std::filesystem::path& scenarios) {
    const std::filesystem::path air = scenarios / "airborne-pass" / "scenario.toml";
    if (!std::filesystem::exists(air)) return;
    const int threads = coresUpTo16();
    using Paths = render::Renderer::PrimaryPaths;
    for (const bool gl : {true, false}) {
        auto f = std::make_shared<Flight>();
        f->file = air;
        f->dirs = dirs;
        f->width = 1920;
        f->height = 1080;
        f->visibility = gl ? render::PrimaryVisibility::kGl : render::PrimaryVisibility::kEmbree;
        f->threads = threads;
        const Paths paths = gl ? Paths::kGl : Paths::kEmbree;
        TimedItem& it = add(items, gl ? "primary_air_1080p_gl" : "primary_air_1080p_embree",
                            std::string("airborne pass at 1920x1080, ") + std::to_string(threads) +
                                " threads, the primary pass alone (the whole geometry buffer) by " +
                                (gl ? "OpenGL" : "Embree packets") + ", camera moving",
                            gl ? std::optional<double>(1.0 / 120.0) : std::nullopt, 1.5);
        it.setup = [f] { f->get(); };
        it.iteration = [f, paths] {
            render::Renderer& r = f->sr->renderer();
            r.setCamera(f->poses[f->next++ % f->poses.size()]);
            (void)r.measurePrimaryPasses(*f->pool, 0, paths);
        };
        it.after = [f, gl, threads](TimedItem& self) {
            render::Renderer& r = f->sr->renderer();
            self.extra.emplace_back("threads", threads);
            if (!gl) return;
            const render::Renderer::PrimaryTiming t =
                r.measurePrimaryPasses(*f->pool, 20, Paths::kGl);
            self.note = r.primaryVisibilityNote();
            if (t.gl_ms < 0.0) {
                self.note += "; the GL pass failed (Embree made the G-buffer)";
                return;
            }
            self.extra.emplace_back("gl_pass_ms", t.gl_ms);
            self.extra.emplace_back("gl_draw_readback_ms", t.glRender_ms);
            self.extra.emplace_back("gbuffer_from_hits_ms", t.gl_ms - t.glRender_ms);
            std::fprintf(stderr, "  %s: %s\n", self.name.c_str(), self.note.c_str());
        };
    }
}

// A thermal channel of the bench items: its scene's heat balance and LWIR table, its camera chain,
// its radiance image (the boresighted item's; the others draw into the flight's band image) and
// the one-thread executor it is timed on.
struct ThermalChannel {
    std::unique_ptr<rt::ThermalScene> scene;
    std::unique_ptr<bolometer::BolometerChain> chain;
    ImageF radiance;
    render::SerialExecutor one;
};

// A thermal channel boresighted with the intensified camera (docs/thermal.md, "Shared primary
// hits"): the airborne pass's 768 × 494 intensified frame is rendered first, untimed (the
// intensified channel's own work); the timed part is what the thermal channel adds on one
// thread: its 640 × 512 pixels take the primary hits of that frame's G-buffer (a 24 mm lens,
// 18.3° × 14.7°, inside the intensified camera's 22.0° × 16.7°: no ray of its own), the thermal
// shading and the bolometer chain. The budget: half of one core at 30 Hz, 16.7 ms a frame.
void addBoresightItem(Items& items, const DataDirs& dirs, const std::filesystem::path& air,
                      const std::filesystem::path& weather) {
    auto f = std::make_shared<Flight>();
    auto th = std::make_shared<ThermalChannel>();
    f->file = air;
    f->dirs = dirs;
    f->threads = 2;
    f->period_s = 1.0 / 30.0;
    TimedItem& it = add(items, "thermal_air_640x512_boresight_1t",
                        "airborne pass: a 640x512 microbolometer boresighted with the 768x494 "
                        "intensified camera, one thread: thermal shading from the intensified "
                        "frame's primary hits and the bolometer chain, camera moving",
                        1.0 / 60.0, 1.5);
    it.setup = [f, th, weather] {
        rt::ScenarioRenderer& sr = f->get();
        bolometer::ThermalCameraParams cam =
            bolometer::loadThermalCamera(f->dirs.config, "boson-640");
        cam.frame_rate_Hz = 30.0;
        rt::ThermalSpec ts;
        ts.weatherFile = weather;
        ts.materialsFile = f->dirs.config / "thermal" / "materials.toml";
        ts.focalLength_mm = 24.0;
        th->scene = rt::ThermalScene::forChannel(sr, cam, ts, f->dirs);
        sr.renderer().setThermalView(
            rt::thermalRenderConfig(cam, ts.focalLength_mm, cam.width, cam.height).camera);
        th->chain = std::make_unique<bolometer::BolometerChain>(cam, 1, f->dirs.config);
        th->radiance = ImageF(cam.width, cam.height);
    };
    it.prepare = [f] { f->renderNext(-1); };
    it.iteration = [f, th] {
        rt::ScenarioRenderer& sr = *f->sr;
        const double t_s = static_cast<double>((f->next - 1) % f->poses.size()) * f->period_s;
        sr.renderer().renderThermal(th->scene->frame(sr.scenario().utcStart_unix_s + t_s),
                                    th->radiance.view(), th->one);
        (void)th->chain->process(th->radiance.cview());
    };
    // The timed part's shares in this thread's CPU time (less disturbed by other load than the
    // wall clock): the shading after the camera moved (each pixel's hit, class, range and
    // emissivity anew), the shading with them kept, the bolometer chain; the mean of 10 each.
    it.after = [f, th](TimedItem& self) {
        render::Renderer& r = f->sr->renderer();
        const render::ThermalFrame& frame = th->scene->frame(f->sr->scenario().utcStart_unix_s);
        double moved_s = 0.0, kept_s = 0.0, chain_s = 0.0;
        for (int i = 0; i < 10; ++i) {
            f->renderNext(-1);
            const double t0 = threadCpu_s();
            r.renderThermal(frame, th->radiance.view(), th->one);
            const double t1 = threadCpu_s();
            r.renderThermal(frame, th->radiance.view(), th->one);
            const double t2 = threadCpu_s();
            (void)th->chain->process(th->radiance.cview());
            const double t3 = threadCpu_s();
            moved_s += t1 - t0;
            kept_s += t2 - t1;
            chain_s += t3 - t2;
        }
        self.extra.emplace_back("shading_moved_ms", moved_s * 100.0);
        self.extra.emplace_back("shading_kept_ms", kept_s * 100.0);
        self.extra.emplace_back("bolometer_ms", chain_s * 100.0);
        self.extra.emplace_back("own_ray_px", static_cast<double>(r.thermalOwnRays()));
    };
}

// The thermal channel on the airborne pass (docs/performance.md, "Thermal channel"): the flight
// seen by a 640 × 512 microbolometer (boson-640, 18 mm lens) with a pose of its own, the camera
// moving a frame (1/30 s) apart, on one thread: each iteration casts the primary rays, shades
// the thermal band and runs the bolometer chain. The budget is half of one core at 30 Hz:
// 16.7 ms a frame. After timing, the bolometer's share (20 frames) goes to the extras.
void addThermalItems(Items& items, const DataDirs& dirs, const std::filesystem::path& scenarios) {
    const std::filesystem::path air = scenarios / "airborne-pass" / "scenario.toml";
    const std::filesystem::path weather =
        dirs.config / "thermal" / "weather" / "rochester-1998-09-02.csv";
    if (!std::filesystem::exists(air) || !std::filesystem::exists(weather)) return;
    auto f = std::make_shared<Flight>();
    auto th = std::make_shared<ThermalChannel>();
    f->file = air;
    f->dirs = dirs;
    f->threads = 1;
    f->width = 640;
    f->height = 512;
    f->adjust = [dirs, weather](rt::Scenario& sc) {
        sc.camera.thermal = true;
        sc.camera.thermalParams = bolometer::loadThermalCamera(dirs.config, "boson-640");
        sc.camera.thermalParams->frame_rate_Hz = 30.0;
        rt::ThermalSpec ts;
        ts.weatherFile = weather;
        ts.materialsFile = dirs.config / "thermal" / "materials.toml";
        sc.scene.thermal = ts;
    };
    // The same frame with the camera held (the geometry buffer and each pixel's class, range
    // and emissivity kept): what a channel that shares its primary hits pays per frame.
    TimedItem& held = add(items, "thermal_air_640x512_held_1t",
                          "airborne pass seen by a 640x512 microbolometer, one thread, camera "
                          "held (primary hits reused): thermal shading and the bolometer chain",
                          1.0 / 60.0, 1.5);
    TimedItem& it = add(items, "thermal_air_640x512_1t",
                        "airborne pass seen by a 640x512 microbolometer with its own pose, one "
                        "thread: primary rays, thermal shading and the bolometer chain, camera "
                        "moving",
                        1.0 / 60.0, 1.5);
    it.setup = [f, th] {
        rt::ScenarioRenderer& sr = f->get();
        if (th->scene) return;
        th->scene = rt::ThermalScene::forScenario(sr, f->dirs);
        th->chain = std::make_unique<bolometer::BolometerChain>(*sr.scenario().camera.thermalParams,
                                                                1, f->dirs.config);
    };
    it.iteration = [f, th] {
        rt::ScenarioRenderer& sr = f->get();
        const std::size_t k = f->next++ % f->poses.size();
        sr.renderer().setCamera(f->poses[k]);
        sr.renderer().renderThermal(
            th->scene->frame(sr.scenario().utcStart_unix_s + static_cast<double>(k) / 30.0),
            f->band.view(), th->one);
        (void)th->chain->process(f->band.cview());
    };
    held.setup = [ip = &it] { ip->setup(); };
    held.iteration = [f, th] {
        rt::ScenarioRenderer& sr = f->get();
        sr.renderer().renderThermal(th->scene->frame(sr.scenario().utcStart_unix_s), f->band.view(),
                                    th->one);
        (void)th->chain->process(f->band.cview());
    };
    it.after = [f, th](TimedItem& self) {
        const auto t0 = std::chrono::steady_clock::now();
        for (int i = 0; i < 20; ++i)
            (void)th->chain->process(f->band.cview());
        const double chain_s =
            std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() / 20.0;
        self.extra.emplace_back("bolometer_ms", chain_s * 1e3);
        self.extra.emplace_back("surface_classes",
                                static_cast<double>(th->scene->surfaces().size()));
    };
    addBoresightItem(items, dirs, air, weather);
}

// The eq. 7.1 reference set up like the camera preset: the same mean photoelectrons per pixel
// (the chain's step 1 on axis, over one integration), the same gain per photoelectron at the
// preset's gain, bias, Gaussian noise and ADC, and a Gaussian MTF that falls to 1/e where the
// tube's exp(−(ξ/ξc)^n) does (ξc referred to the CCD through the taper, in cycles per pixel).
rt::bench::Eq71Params eq71ParamsFor(const sensor::CameraParams& cam) {
    rt::bench::Eq71Params p;
    p.width = cam.width;
    p.height = cam.height;
    p.pe_per_input = cam.peRatePerLpe_on_axis() * cam.integrationPeriod_s();
    const double fc_cyc_px = cam.ii_fc_cyc_mm * cam.taper_magnification * cam.pitch_x_um * 1e-3;
    p.mtf_sigma_px = 1.0 / (std::sqrt(2.0) * kPi * fc_cyc_px);
    p.gain_dc_per_pe = cam.dcPerPhotoelectron(cam.gain_V);
    p.bias_dc = cam.video_offset_dc;
    p.noise_dc = cam.video_noise_dc;
    p.adc_bits = cam.adc_bits;
    return p;
}

// The photoelectron radiance of a RIT scenario's first frame, for the camera items.
void renderInto(const std::filesystem::path& file, const DataDirs& dirs,
                const sensor::CameraParams& cam, ImageView<float> lpe) {
    auto sr = rt::ScenarioRenderer::create(file, dirs, 1);
    if (sr->scenario().width != cam.width || sr->scenario().height != cam.height) {
        throw SetupError(file.string() + ": not the camera's size");
    }
    ImageF band(cam.width, cam.height);
    rt::RowPool pool(1);
    sr->renderFrame(0.0, lpe, band.view(), pool);
}

// The camera chain, one field, every stage of the PULNiX preset, on one thread and on two (the
// calling thread and one pool worker running its bands: the same bits), on the photoelectron
// radiance of the thesis scenes (rendered once: Moon and sky only, and with the street lamp
// on) and on a uniform bright field where every pixel draws; the eq. 7.1 reference on the same
// frames.
void addCameraItems(Items& items, const DataDirs& dirs, const std::filesystem::path& rit) {
    struct Camera {
        sensor::CameraParams cam;
        GammaTableCache gammaTables;
        std::unique_ptr<sensor::IiccdChain> chain;
        std::unique_ptr<sensor::IiccdChain> chain2t;
        std::unique_ptr<rt::RowPool> pool;  // chain2t's second thread
        std::unique_ptr<rt::bench::Eq71Reference> reference;
        std::vector<std::uint16_t> out;
    };
    auto c = std::make_shared<Camera>();
    auto cameraSetup = [c, dirs] {
        if (c->chain) return;
        c->cam = sensor::loadCamera(dirs.config, "pulnix-ag5745ef3");
        c->chain = std::make_unique<sensor::IiccdChain>(c->cam, 1, dirs.config, c->gammaTables);
        c->chain2t = std::make_unique<sensor::IiccdChain>(c->cam, 1, dirs.config, c->gammaTables);
        c->pool = std::make_unique<rt::RowPool>(2);
        c->chain2t->setExecutor(c->pool.get());
        c->reference = std::make_unique<rt::bench::Eq71Reference>(eq71ParamsFor(c->cam));
        c->out.assign(static_cast<std::size_t>(c->cam.width) * c->cam.height, 0);
    };
    struct Input {
        const char* name;
        const char* scene;  // RIT scenario file, or nullptr: uniform
        const char* what;
    };
    for (const Input& in : {Input{"rit_nolight", "nolight.toml", "RIT nolight render"},
                            Input{"rit_stlamp", "stlamp.toml", "RIT stlamp render"},
                            Input{"uniform", nullptr, "uniform 1e13 pe/s/m2/sr"}}) {
        const std::filesystem::path file = in.scene ? rit.parent_path() / in.scene : "";
        if (in.scene != nullptr && !std::filesystem::exists(file)) continue;
        auto lpe = std::make_shared<ImageF>();
        auto flat = std::make_shared<std::vector<float>>();  // the same, rows contiguous
        auto frameSetup = [c, lpe, flat, cameraSetup, file, dirs] {
            cameraSetup();
            if (lpe->width() != 0) return;
            *lpe = ImageF(c->cam.width, c->cam.height);
            if (file.empty()) {
                lpe->fill(1e13f);
            } else {
                renderInto(file, dirs, c->cam, lpe->view());
            }
            for (int y = 0; y < lpe->height(); ++y)
                flat->insert(flat->end(), lpe->row(y), lpe->row(y) + lpe->width());
        };
        TimedItem& ch =
            add(items, std::string("sensor_chain_") + in.name,
                std::string("IICCD chain, one field 768x494, one thread, ") + in.what, 6e-3, 2.0);
        ch.setup = frameSetup;
        ch.iteration = [c, lpe] { c->chain->process(lpe->cview()); };
        ch.after = [c, lpe](TimedItem& self) {
            self.extra.emplace_back("mean_pe_per_px", c->chain->process(lpe->cview()).mean_pe);
        };
        TimedItem& ch2 =
            add(items, std::string("sensor_chain_2t_") + in.name,
                std::string("IICCD chain, one field 768x494, two threads, ") + in.what, 6e-3, 2.0);
        ch2.setup = frameSetup;
        ch2.iteration = [c, lpe] { c->chain2t->process(lpe->cview()); };
        ch2.after = [c, lpe](TimedItem& self) {
            self.extra.emplace_back("mean_pe_per_px", c->chain2t->process(lpe->cview()).mean_pe);
        };
        TimedItem& ref = add(items, std::string("eq71_reference_") + in.name,
                             std::string("plain eq. 7.1 model (Poisson, FFT Gaussian MTF, ") +
                                 "Gaussian noise, gain/bias), 768x494, one thread, " + in.what,
                             std::nullopt, 2.0);
        ref.setup = frameSetup;
        ref.iteration = [c, flat] { c->reference->process(flat->data(), c->out.data()); };
    }
}

// A frame-sized memory copy: the floor any per-frame stage stands on.
void addMemcpyItems(Items& items) {
    constexpr std::size_t kPixels = std::size_t{768} * 494;
    auto f = std::make_shared<std::vector<float>>(2 * kPixels, 1.0f);
    auto u = std::make_shared<std::vector<std::uint16_t>>(2 * kPixels, 1);
    TimedItem& a =
        add(items, "memcpy_frame_f32", "memcpy of 768x494 float (1.5 MB)", std::nullopt, 0.5);
    a.iteration = [f] { std::memcpy(f->data() + kPixels, f->data(), kPixels * sizeof(float)); };
    TimedItem& b =
        add(items, "memcpy_frame_u16", "memcpy of 768x494 uint16 (0.76 MB)", std::nullopt, 0.5);
    b.iteration = [u] {
        std::memcpy(u->data() + kPixels, u->data(), kPixels * sizeof(std::uint16_t));
    };
}

// The end-to-end runs the filter keeps, as JSON objects (before any thread exists: they fork).
std::vector<std::string> runEndToEndItems(const DataDirs& dirs,
                                          const std::filesystem::path& scenarios,
                                          const std::function<bool(const std::string&)>& wanted) {
    std::vector<rt::bench::EndToEndRequest> reqs(3);
    reqs[0].name = "e2e_airborne_pass_768x494i";
    reqs[0].what =
        "scenarios/airborne-pass, 768x494 interlaced, moving platform, every camera "
        "stage, sim clock, y4m to /dev/null";
    reqs[0].scenario = scenarios / "airborne-pass" / "scenario.toml";
    reqs[0].targetFields_per_s = 59.94;
    reqs[1].name = "e2e_airborne_pass_sxga_1280x1024p";
    reqs[1].what =
        "scenarios/airborne-pass-sxga, 1280x1024 progressive, moving platform, "
        "sim clock, y4m to /dev/null";
    reqs[1].scenario = scenarios / "airborne-pass-sxga" / "scenario.toml";
    reqs[1].targetFields_per_s = 30.0;
    // The same with the primary pass by OpenGL (a GPU through EGL where there is one), the
    // render's rows on every core (at most 16) and the camera chain's on half of them.
    const int threads = coresUpTo16();
    const int cameraThreads =
        std::clamp(static_cast<int>(std::thread::hardware_concurrency()) / 2, 1, 16);
    reqs[2] = reqs[1];
    reqs[2].name = "e2e_airborne_pass_sxga_1280x1024p_gl";
    reqs[2].what = reqs[1].what + ", primary visibility by OpenGL, " + std::to_string(threads) +
                   " render threads, " + std::to_string(cameraThreads) + " camera threads";
    reqs[2].primaryVisibility = render::PrimaryVisibility::kGl;
    reqs[2].renderThreads = threads;
    reqs[2].cameraThreads = cameraThreads;
    std::vector<std::string> out;
    for (rt::bench::EndToEndRequest& q : reqs) {
        if (!wanted(q.name) || !std::filesystem::exists(q.scenario)) continue;
        q.dirs = dirs;
        // The flight log lasts 2.4 s: 70 frames keep the platform moving to the end.
        q.warmFrames = 20;
        q.frames = 70;
        const rt::bench::EndToEndResult r = rt::bench::runEndToEnd(q);
        if (r.ok) {
            std::fprintf(stderr,
                         "  %-34s %.2f fields/s (target %.2f)  field period p50 %.3f ms p99 %.3f "
                         "ms  peak RSS %.0f MiB  steady allocations %lld in %lld fields\n",
                         q.name.c_str(), r.fields_per_s, q.targetFields_per_s,
                         r.period_p50_s / r.fieldsPerFrame * 1e3,
                         r.period_p99_s / r.fieldsPerFrame * 1e3, r.peakRss_MiB,
                         static_cast<long long>(r.steadyAllocations),
                         static_cast<long long>(r.steadyFields));
        } else {
            std::fprintf(stderr, "  %-34s error: %s\n", q.name.c_str(), r.error.c_str());
        }
        out.push_back(rt::bench::endToEndJson(q, r));
    }
    return out;
}

const TimedItem* find(const Items& items, const std::string& name) {
    for (const auto& it : items) {
        if (it->name == name && it->ran) return it.get();
    }
    return nullptr;
}

double extra(const TimedItem& it, const std::string& key) {
    for (const auto& [k, v] : it.extra) {
        if (k == key) return v;
    }
    return 0.0;
}

// The ratios the issue asks for, from the items of this run (each only when both ran).
std::string ratiosJson(const Items& items) {
    std::string j;
    const auto put = [&j](const std::string& key, double v) {
        char buf[160];
        std::snprintf(buf, sizeof buf, "%s\"%s\":%.4g", j.empty() ? "" : ",", key.c_str(), v);
        j += buf;
    };
    // Renderer rays/s (primary + shadow + secondary per render, one thread) over Embree's own
    // single-ray rate on the same view.
    if (const TimedItem* e = find(items, "embree_single_primary")) {
        for (const char* r : {"render_full_1t", "render_full_1t_moving", "render_coarse4_1t",
                              "render_coarse4_1t_moving"}) {
            if (const TimedItem* it = find(items, r)) {
                put(std::string(r) + "_rays_per_s_over_embree_single",
                    extra(*it, "rays_per_s") / extra(*e, "rays_per_s"));
            }
        }
    }
    for (const char* in : {"rit_nolight", "rit_stlamp", "uniform"}) {
        const TimedItem* chain = find(items, std::string("sensor_chain_") + in);
        const TimedItem* ref = find(items, std::string("eq71_reference_") + in);
        const TimedItem* mem = find(items, "memcpy_frame_f32");
        if (chain && ref)
            put(std::string("eq71_reference_over_chain_") + in, ref->p50_s / chain->p50_s);
        if (chain && mem)
            put(std::string("chain_") + in + "_over_memcpy_f32", chain->p50_s / mem->p50_s);
        if (const TimedItem* chain2 = find(items, std::string("sensor_chain_2t_") + in);
            chain2 && ref)
            put(std::string("eq71_reference_over_chain_2t_") + in, ref->p50_s / chain2->p50_s);
    }
    return "{" + j + "}";
}

// The run as one JSON object (docs/contracts.md, "bench"), on stdout and to --json OUT.
int writeBenchJson(const Items& items, const std::vector<std::string>& e2e,
                   const rt::bench::MachineInfo& machine, const double (&loadStart)[3],
                   const std::vector<std::string>& notes, const BenchOptions& opts,
                   OutputFiles& outputs) {
    std::string json = "{\"benchmarks\":[";
    bool first = true;
    for (const auto& it : items) {
        if (!it->ran && it->error.empty()) continue;
        json += (first ? "" : ",") + rt::bench::timedItemJson(*it);
        first = false;
    }
    json += "],\"end_to_end\":[";
    for (std::size_t i = 0; i < e2e.size(); ++i)
        json += (i ? "," : "") + e2e[i];
    // The machine: CPUs, clock, and the load averages (1, 5, 15 min; getloadavg(3)) when the
    // run started and when it ended: the machine is shared, a figure is only as quiet as this.
    double loadEnd[3] = {0.0, 0.0, 0.0};
    if (getloadavg(loadEnd, 3) != 3) loadEnd[0] = loadEnd[1] = loadEnd[2] = -1.0;
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  ",\"machine\":{\"cpus\":%u,\"mhz\":%.0f,"
                  "\"load_avg_start\":[%.2f,%.2f,%.2f],\"load_avg_end\":[%.2f,%.2f,%.2f]}",
                  std::thread::hardware_concurrency(), machine.mhz, loadStart[0], loadStart[1],
                  loadStart[2], loadEnd[0], loadEnd[1], loadEnd[2]);
    json += "],\"ratios\":" + ratiosJson(items) + buf;
    if (!notes.empty()) {
        json += ",\"notes\":[";
        for (std::size_t i = 0; i < notes.size(); ++i)
            json += (i ? ",\"" : "\"") + rt::jsonEscape(notes[i]) + "\"";
        json += "]";
    }
    json += "}\n";
    std::fputs(json.c_str(), stdout);
    if (opts.json) {
        outputs.holdSignals();
        outputs.writeText(*opts.json, json);
        outputs.commit();
    }
    return kExitOk;
}

}  // namespace

int runBench(const BenchOptions& opts) {
    const auto wanted = [&](const std::string& name) {
        return rt::bench::filterKeeps(opts.filter, name);
    };
    // The shipped scenarios lie beside config/ (in the source tree and in an installed tree).
    const DataDirs dirs = resolveDataDirs();
    // --json checked before the benchmarks run (sim/core/output_file.h).
    OutputFiles outputs;
    if (opts.json) outputs.addFile("--json", *opts.json);
    const std::filesystem::path scenarios = dirs.config.parent_path() / "scenarios";
    const std::filesystem::path rit = scenarios / "rit" / "stlamp.toml";
    const std::filesystem::path drive = scenarios / "vehicle-drive" / "scenario.toml";
    std::vector<std::string> notes;
    double loadStart[3] = {0.0, 0.0, 0.0};
    if (getloadavg(loadStart, 3) != 3) loadStart[0] = loadStart[1] = loadStart[2] = -1.0;
    // End to end first: each run forks, which wants a process without threads.
    const std::vector<std::string> e2e = runEndToEndItems(dirs, scenarios, wanted);

    Items items;
    addAstroSkyItems(items, dirs);
    if (std::filesystem::exists(rit)) {
        addRenderItems(items, dirs, rit);
        addCameraItems(items, dirs, rit);
    } else {
        notes.push_back("RIT scenario not found at " + rit.string());
    }
    if (std::filesystem::exists(drive)) addTruckItems(items, dirs, drive);
    addAirborneItems(items, dirs, scenarios);
    addPrimary1080Items(items, dirs, scenarios);
    addThermalItems(items, dirs, scenarios);
    addMemcpyItems(items);
    bool any = !e2e.empty();
    for (const auto& it : items)
        any = any || wanted(it->name);
    if (!any && opts.filter) {
        throw SetupError("--filter: no benchmark name contains any of '" + *opts.filter + "'");
    }
    const rt::bench::MachineInfo machine = rt::bench::runTimedItems(items, opts.filter);
    return writeBenchJson(items, e2e, machine, loadStart, notes, opts, outputs);
}

}  // namespace nvs::cli
