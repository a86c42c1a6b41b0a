#include "rt/compose/thermal_scene.h"

#include <algorithm>
#include <cmath>
#include <string>

#include "sim/core/error.h"
#include "sim/core/units.h"

namespace nvs::rt {
namespace {

// The Sun's direction (east, north, up) at POSIX time t_s.
Vec3 towardSun(const astro::Ephemeris& eph, const astro::AstroTime& epoch, double epoch_s,
               double t_s, double* alt_rad) {
    const msg::SunState sun = eph.compute(epoch.plusSeconds(t_s - epoch_s)).sun;
    *alt_rad = sun.alt_rad;
    const double c = std::cos(sun.alt_rad);
    return {c * std::sin(sun.az_rad), c * std::cos(sun.az_rad), std::sin(sun.alt_rad)};
}

}  // namespace

ThermalScene::ThermalScene(const scene::Scene& scene, render::Renderer& renderer,
                           const astro::Site& site, const astro::AstroTime& epoch, double epoch_s,
                           double start_s, double end_s, const ThermalSceneSpec& spec,
                           const DataDirs& dirs)
    : library_(thermal::MaterialLibrary::load(spec.materialsFile)),
      weather_(thermal::WeatherSeries::load(spec.weatherFile)) {
    surfaces_ = renderer.prepareThermal();
    buildClasses(scene, renderer, site, epoch, epoch_s, start_s, end_s, spec);
    table_ = thermal::solveHeatBalance(classes_, weather_, site, spec.heat, start_s, end_s,
                                       dirs.cache, &report_);
    const thermal::WeatherSample w = weather_.at(start_s);
    const lwir::LwirTableInputs in = lwir::LwirTableInputs::fromWeather(
        w.air_K, w.dewPoint_K, spec.pressure_Pa, w.cloudFraction, w.cloudBase_m, spec.band);
    lwir_ = std::make_unique<lwir::LwirTable>(lwir::LwirTable::loadOrBuild(in, dirs));
    fillTables();
    frame(start_s);
}

void ThermalScene::buildClasses(const scene::Scene& scene, const render::Renderer& renderer,
                                const astro::Site& site, const astro::AstroTime& epoch,
                                double epoch_s, double start_s, double end_s,
                                const ThermalSceneSpec& spec) {
    // The Sun through the history the heat balance runs over (a day before the table).
    const astro::Ephemeris eph(site);
    std::vector<double> times;
    std::vector<Vec3> sun;
    std::vector<double> alt;
    for (double t = start_s - 86400.0; t <= end_s + spec.shadowStep_s; t += spec.shadowStep_s) {
        double a = 0.0;
        sun.push_back(towardSun(eph, epoch, epoch_s, t, &a));
        alt.push_back(a);
        times.push_back(t);
    }
    for (const render::ThermalSurface& s : surfaces_) {
        const scene::Material& sm = scene.materials[static_cast<std::size_t>(s.material)];
        if (sm.thermal.empty()) {
            throw SetupError(sm.loc, "material '" + sm.name +
                                         "' has no `thermal` material (config/thermal/"
                                         "materials.toml names them), needed by the thermal "
                                         "channel");
        }
        thermal::SurfaceClass c;
        c.name = sm.name + " (tilt " + std::to_string(static_cast<int>(s.tilt_rad * 180.0 / kPi)) +
                 "°, sky view " + std::to_string(s.skyView).substr(0, 4) + ")";
        c.material = library_.requireThermal(sm.thermal, sm.thermalLoc);
        c.exposure.orientation.tilt_rad = s.tilt_rad;
        c.exposure.orientation.azimuth_rad = s.azimuth_rad;
        c.exposure.skyView = std::clamp(s.skyView, 0.0, 1.0);
        c.sunlitTimes_s = times;
        c.sunlitFraction.resize(times.size());
        for (std::size_t k = 0; k < times.size(); ++k)
            c.sunlitFraction[k] = alt[k] > 0.0 ? renderer.sunlitFraction(s, sun[k]) : 0.0;
        classes_.push_back(std::move(c));
    }
}

void ThermalScene::fillTables() {
    const std::size_t n = surfaces_.size();
    temperature_K_.assign(n, 0.0f);
    emissivity_.assign(n * render::kThermalCosBins, 0.0f);
    for (std::size_t i = 0; i < n; ++i) {
        for (int b = 0; b < render::kThermalCosBins; ++b) {
            const double cosT = static_cast<double>(b) / (render::kThermalCosBins - 1);
            emissivity_[i * render::kThermalCosBins + static_cast<std::size_t>(b)] =
                static_cast<float>(thermal::directionalEmissivity(classes_[i].material, cosT));
        }
    }
    constexpr double kT0_K = 150.0, kStep_K = 0.1;
    constexpr int kTemps = 3501;  // 150–500 K
    blackbody_.resize(kTemps);
    for (int i = 0; i < kTemps; ++i)
        blackbody_[static_cast<std::size_t>(i)] =
            static_cast<float>(lwir_->blackbody_W_m2_sr(kT0_K + kStep_K * i));
    const double ln0 = std::log(lwir::LwirTable::kMinRange_m);
    const double ln1 = std::log(lwir::LwirTable::kMaxRange_m);
    constexpr int kRanges = 256;
    const double step = (ln1 - ln0) / (kRanges - 1);
    tau_.resize(kRanges);
    path_.resize(kRanges);
    for (int i = 0; i < kRanges; ++i) {
        const lwir::PathBand p = lwir_->path(std::exp(ln0 + step * i));
        tau_[static_cast<std::size_t>(i)] = static_cast<float>(p.transmittance);
        path_[static_cast<std::size_t>(i)] = static_cast<float>(p.pathRadiance_W_m2_sr);
    }
    constexpr int kSky = 91;
    sky_.resize(kSky);
    for (int i = 0; i < kSky; ++i)
        sky_[static_cast<std::size_t>(i)] =
            static_cast<float>(lwir_->skyRadiance_W_m2_sr(i * kPi / 180.0));
    for (std::size_t i = 0; i < n; ++i) {
        if (surfaces_[i].tilt_rad < 22.5 * kPi / 180.0 && surfaces_[i].skyView > 0.75)
            groundClasses_.push_back(i);
    }
    frame_.surfaceTemperature_K = temperature_K_.data();
    frame_.emissivity = emissivity_.data();
    frame_.blackbody = blackbody_.data();
    frame_.blackbodyT0_K = kT0_K;
    frame_.blackbodyStep_K = kStep_K;
    frame_.blackbodyCount = kTemps;
    frame_.pathTau = tau_.data();
    frame_.pathRadiance = path_.data();
    frame_.lnRange0 = ln0;
    frame_.lnRangeStep = step;
    frame_.rangeCount = kRanges;
    frame_.skyRadiance = sky_.data();
    frame_.skyCount = kSky;
    frame_.skyDiffuse = lwir_->skyDiffuseRadiance_W_m2_sr();
}

const render::ThermalFrame& ThermalScene::frame(double t_s) noexcept {
    for (std::size_t i = 0; i < temperature_K_.size(); ++i)
        temperature_K_[i] = static_cast<float>(table_.at(i, t_s));
    frame_.groundRadiance = groundRadianceAt(t_s);
    return frame_;
}

double ThermalScene::groundRadianceAt(double t_s) const noexcept {
    double area = 0.0, sum = 0.0;
    for (const std::size_t i : groundClasses_) {
        const double a = surfaces_[i].area_m2;
        area += a;
        sum += a * lwir_->blackbody_W_m2_sr(table_.at(i, t_s));
    }
    return area > 0.0 ? sum / area : lwir_->blackbody_W_m2_sr(weather_.at(t_s).air_K);
}

std::unique_ptr<ThermalScene> ThermalScene::forScenario(ScenarioRenderer& sr,
                                                        const DataDirs& dirs) {
    const Scenario& sc = sr.scenario();
    return forChannel(sr, *sc.camera.thermalParams, *sc.scene.thermal, dirs);
}

std::unique_ptr<ThermalScene> ThermalScene::forChannel(ScenarioRenderer& sr,
                                                       const bolometer::ThermalCameraParams& cam,
                                                       const ThermalSpec& ts,
                                                       const DataDirs& dirs) {
    const Scenario& sc = sr.scenario();
    ThermalSceneSpec spec;
    spec.weatherFile = ts.weatherFile;
    spec.materialsFile = ts.materialsFile;
    spec.heat = ts.heat;
    spec.band = lwir::BandResponse::flat(cam.band_lo_um, cam.band_hi_um);
    sr.prepare(0.0);
    const double end_s = sc.utcStart_unix_s + std::max(sc.duration_s.value_or(60.0), 60.0);
    return std::make_unique<ThermalScene>(sr.scene(), sr.renderer(), sc.scene.site, sr.epoch(),
                                          sc.utcStart_unix_s, sc.utcStart_unix_s, end_s, spec,
                                          dirs);
}

}  // namespace nvs::rt
