// The thesis's illuminance and ephemeris tables as measured datasets for `nvstim diagnose`
// (docs/validation.md, "The thesis's tables as datasets"), behind `make validate`.
//
// The tables give one number per instant (a horizontal illuminance, a Moon altitude), not
// frames. Each dataset is the RIT roof (scenarios/rit) rendered from a scenario at the table's
// night, a frame every 15 minutes, and realised through the PULNiX camera: every frame's radiance
// is nvstim's rendering of that instant scaled so that the scene's horizontal illuminance is the
// table's. The scene's light then keeps nvstim's spatial pattern (shadows, the direct/sky split);
// what the frames carry from the table is its level at the table's instants (an hour or two
// apart); frames between them take the realisation factor interpolated linearly in time.
//
//   t8-2_night_illuminance  Tables 8-2 and 10-1: the full-moon night of 9/6/98, 9 PM - 4 AM EDT.
//                           make_adb's total (direct Moon + 0.0012 lx night sky, no lunar sky
//                           light, the Moon at its airless altitude, Table 10-1). Model under
//                           test: nvstim's scene with the lunar sky light left out, as make_adb
//                           did (lunar_sky_scale = 0).
//   t8-3_lunar_scattering   Table 8-3: the same night with the thesis's own estimate of the lunar
//                           sky light added: 0.031 lx where make_adb gave 0.023 (the Moon lowest,
//                           9 PM) and 0.128 where it gave 0.121 (highest, 2 AM); between them
//                           the added light is linear in the Moon's altitude. Model: as above.
//   t4-2_moon_ephemeris     Table 4-2: the night of 9/1/98, 9:30 PM - 2 AM EDT (the rows from
//                           10 PM have the Moon up and the Sun below -18°). The Moon at the table's
//                           altitude (ephem's, refracted): each frame scaled by nvstim's horizontal
//                           illuminance at the table's altitude over that at its own. Model:
//                           nvstim as it ships (lunar sky light, refraction at the site).
//
//   nvs_thesis_scene_datasets THESIS_CSV_DIR OUT_DIR

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <string>
#include <vector>

#include "rt/compose/scene_stimulus.h"
#include "sim/astro/ephemeris.h"
#include "sim/astro/time.h"
#include "sim/core/csv.h"
#include "sim/core/units.h"
#include "sim/fit/generate.h"
#include "sim/fit/generate_scene.h"
#include "sim/sky/sky_model.h"

namespace {

using namespace nvs;
namespace fs = std::filesystem;

constexpr double kFramePeriod_s = 900.0;  // a frame every 15 minutes
constexpr double kSiteHeight_m = 218.0;   // as fit::writeSceneScenario's site
constexpr double kVisibility_km = 23.0;   // thesis §9.1: clear sky, 23 km
// Table 8-2's night: 9 PM to 4 AM EDT.
constexpr const char* kNightStart = "1998-09-07T01:00:00Z";  // 9/6/98 9 PM EDT
constexpr int kNightFrames = 29;
// Table 18-5's gain.
constexpr double kGain_V = 5.5;

// One instant of a table: its time (seconds after the dataset's start) and the level the
// frame's realisation needs there (meaning per dataset).
struct Row {
    double t_s = 0.0;
    double value = 0.0;
};

double interpolate(const std::vector<Row>& rows, double t_s) {
    if (t_s <= rows.front().t_s) return rows.front().value;
    for (std::size_t i = 1; i < rows.size(); ++i)
        if (t_s <= rows[i].t_s) {
            const double u = (t_s - rows[i - 1].t_s) / (rows[i].t_s - rows[i - 1].t_s);
            return rows[i - 1].value + u * (rows[i].value - rows[i - 1].value);
        }
    return rows.back().value;
}

double secondsBetween(const std::string& isoFrom, const std::string& isoTo) {
    const astro::AstroTime a = astro::astroTimeFromUtc(astro::parseIsoUtc(isoFrom, isoFrom));
    const astro::AstroTime b = astro::astroTimeFromUtc(astro::parseIsoUtc(isoTo, isoTo));
    return ((b.ut1Jd1 - a.ut1Jd1) + (b.ut1Jd2 - a.ut1Jd2)) * 86400.0;
}

struct Context {
    fs::path config, scene;
    DataDirs dirs;
    fit::SceneStimulusFactory factory;
    astro::Ephemeris ephemeris;
    sky::SkyModel sky;
};

// The night sky terms nvstim gives at `iso` (lux, horizontal).
sky::HorizontalTerms horizontalAt(const Context& c, const std::string& iso,
                                  astro::MoonState* moon = nullptr) {
    const astro::SunMoonState s =
        c.ephemeris.compute(astro::astroTimeFromUtc(astro::parseIsoUtc(iso, iso)));
    if (moon) *moon = s.moon;
    return c.sky.horizontal(sky::SkyModel::kLuxBand, s.moon);
}

// Renders the scenario (the model's effects `model`) for `frames` frames from utcStart
// and writes the dataset whose frame k is the camera's video of realise(k, L0, L1), where L0 is
// the rendering with the lunar sky light left out and L1 with it (nvstim's own).
void writeDataset(const Context& c, const fs::path& dir, const std::string& utcStart, int frames,
                  const fit::SkyEffects& model,
                  const std::function<float(int k, float l0, float l1)>& realise) {
    fs::create_directories(dir);
    fit::Dataset d;
    d.scenario = dir / "scenario.toml";
    fit::SceneSetup setup;  // the scene's own camera, no lamps
    setup.utcStart = utcStart;
    setup.framePeriod_s = kFramePeriod_s;
    setup.gain_V = kGain_V;
    fit::writeSceneScenario(d.scenario, c.scene, model, setup);
    char gain[32];
    std::snprintf(gain, sizeof gain, "%g", kGain_V);
    // Frame scan: each frame of the night is its own exposure.
    fit::prepareSceneDataset(d, "pulnix-ag5745ef3",
                             {{"width", "128"},
                              {"height", "96"},
                              {"agc", "\"off\""},
                              {"gain_V", gain},
                              {"video.scan", "\"frame\""}},
                             128, 96, frames, kFramePeriod_s, c.factory, c.config);
    fit::SkyEffects without = model, with = model;
    without.lunarSkyScale = 0.0;
    with.lunarSkyScale = 1.0;
    const std::vector<ImageF> l0 = d.scene->render(d.frameNumbers, d.frameRate_Hz, without, {});
    const std::vector<ImageF> l1 = d.scene->render(d.frameNumbers, d.frameRate_Hz, with, {});
    std::vector<ImageF> seen;
    for (int k = 0; k < frames; ++k) {
        ImageF img(d.width, d.height);
        for (int y = 0; y < d.height; ++y)
            for (int x = 0; x < d.width; ++x)
                img(x, y) = realise(k, l0[static_cast<std::size_t>(k)](x, y),
                                    l1[static_cast<std::size_t>(k)](x, y));
        seen.push_back(std::move(img));
    }
    const sensor::CameraParams cam = sensor::loadCamera(c.config, d.preset, d.settings);
    fit::makeFrames(cam, 1998, seen, c.config, d);
    d.scene.reset();
    d.scenario = "scenario.toml";  // beside dataset.toml
    fit::writeDataset(d, dir);
}

// Table 8-2's night rows (Moon up, Sun below -12°: the 6 AM row's 0.61 lx of twilight is out
// of the night sky model's scope): time and make_adb's total illuminance.
std::vector<Row> table8_2Night(const CsvTable& t, const std::string& utcStart, const Context& c) {
    const auto cTime = t.column("time_local_iso_edt_assumed");
    const auto cSun = t.column("sun_elevation_deg");
    const auto cMoon = t.column("moon_elevation_deg");
    const auto cTotal = t.column("total_illuminance_lux");
    std::vector<Row> ratio;  // make_adb total over nvstim's direct Moon + night sky
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        if (t.empty(r, cMoon) || t.number(r, cSun) > -12.0 || t.number(r, cMoon) <= 0.0) continue;
        const std::string& iso = t.row(r)[cTime];
        const sky::HorizontalTerms h = horizontalAt(c, iso);
        const double adb = t.number(r, cTotal);
        ratio.push_back({secondsBetween(utcStart, iso), adb / (h.moonDirect + h.nightSky)});
        std::printf("  %s make_adb %.4f lx, nvstim direct + night sky %.4f lx, lunar sky %.4f lx\n",
                    iso.c_str(), adb, h.moonDirect + h.nightSky, h.moonSky);
    }
    return ratio;
}

// `k`: Table 8-2's night as table8_2Night gives it.
void night8_2(const Context& c, const std::vector<Row>& k, const fs::path& out) {
    std::printf("t8-2_night_illuminance (Tables 8-2, 10-1)\n");
    fit::SkyEffects model;
    model.lunarSkyScale = 0.0;
    writeDataset(c, out / "t8-2_night_illuminance", kNightStart, kNightFrames, model,
                 [&](int f, float l0, float) {
                     return static_cast<float>(interpolate(k, f * kFramePeriod_s)) * l0;
                 });
}

// `k`: Table 8-2's night as table8_2Night gives it.
void lunarScattering8_3(const Context& c, const std::vector<Row>& k, const fs::path& thesis,
                        const fs::path& out) {
    const CsvTable t8_3 =
        CsvTable::load(thesis / "table8-3_illuminance_literature_vs_make_adb.csv");
    std::printf("t8-3_lunar_scattering (Tables 8-2, 8-3):\n");
    // The full-moon row: make_adb's range and the thesis's estimate with lunar scattering.
    std::size_t full = t8_3.rowCount();
    for (std::size_t r = 0; r < t8_3.rowCount(); ++r)
        if (t8_3.row(r)[t8_3.column("condition")] == "Full moon") full = r;
    if (full == t8_3.rowCount()) throw SetupError(t8_3.file() + ": no 'Full moon' row");
    const double addLow = t8_3.number(full, t8_3.column("with_est_lunar_scattering_low_lux")) -
                          t8_3.number(full, t8_3.column("make_adb_low_lux"));
    const double addHigh = t8_3.number(full, t8_3.column("with_est_lunar_scattering_high_lux")) -
                           t8_3.number(full, t8_3.column("make_adb_high_lux"));
    // The estimate's two ends at the night's lowest (first row) and highest Moon; the added
    // light linear in the Moon's altitude between them; its share of nvstim's lunar sky light.
    const astro::AstroTime t0 = astro::astroTimeFromUtc(astro::parseIsoUtc(kNightStart));
    std::vector<double> altitude_deg, share;
    for (int f = 0; f < kNightFrames; ++f) {
        const astro::MoonState m = c.ephemeris.compute(t0.plusSeconds(f * kFramePeriod_s)).moon;
        altitude_deg.push_back(m.alt_rad * kDegPerRad);
        share.push_back(c.sky.horizontal(sky::SkyModel::kLuxBand, m).moonSky);
    }
    const double altLow = altitude_deg.front();
    const double altHigh = *std::max_element(altitude_deg.begin(), altitude_deg.end());
    for (int f = 0; f < kNightFrames; ++f) {
        const double u = std::clamp((altitude_deg[f] - altLow) / (altHigh - altLow), 0.0, 1.0);
        const double added = addLow + u * (addHigh - addLow);
        std::printf("  frame %d: Moon %.1f deg, added %.4f lx = %.3f of nvstim's lunar sky light\n",
                    f, altitude_deg[f], added, added / share[f]);
        share[f] = added / share[f];
    }
    fit::SkyEffects model;
    model.lunarSkyScale = 0.0;
    writeDataset(c, out / "t8-3_lunar_scattering", kNightStart, kNightFrames, model,
                 [&](int f, float l0, float l1) {
                     const double kf = interpolate(k, f * kFramePeriod_s);
                     return static_cast<float>(
                         kf * double{l0} + share[static_cast<std::size_t>(f)] * double{l1 - l0});
                 });
}

void ephemeris4_2(const Context& c, const fs::path& thesis, const fs::path& out) {
    const CsvTable t = CsvTable::load(thesis / "table4-1_4-2_ephemeris_collection_nights.csv");
    const auto cTable = t.column("table");
    const auto cTime = t.column("local_time_iso_edt");
    const auto cAlt = t.column("moon_elevation_deg");
    // Two frames before the table's first row: diagnose leaves a dataset's first two frames out
    // (the camera settling).
    const std::string start = "1998-09-02T01:30:00Z";  // 9/1/98 9:30 PM EDT
    const std::string first = "1998-09-02T02:00:00Z", last = "1998-09-02T06:00:00Z";
    std::printf("t4-2_moon_ephemeris (Table 4-2):\n");
    std::vector<Row> scale;  // nvstim's illuminance at the table's altitude over at its own
    for (std::size_t r = 0; r < t.rowCount(); ++r) {
        const std::string& iso = t.row(r)[cTime];
        if (t.row(r)[cTable] != "4-2") continue;
        if (secondsBetween(first, iso) < -1.0 || secondsBetween(iso, last) < -1.0) continue;
        astro::MoonState moon;
        const sky::HorizontalTerms own = horizontalAt(c, iso, &moon);
        astro::MoonState table = moon;
        table.alt_rad = t.number(r, cAlt) / kDegPerRad;
        const sky::HorizontalTerms at = c.sky.horizontal(sky::SkyModel::kLuxBand, table);
        std::printf("  %s Moon %.2f deg (table) vs %.2f deg (nvstim): illuminance x %.4f\n",
                    iso.c_str(), t.number(r, cAlt), moon.alt_rad * kDegPerRad,
                    at.total / own.total);
        scale.push_back({secondsBetween(start, iso), at.total / own.total});
    }
    if (scale.size() != 5) throw SetupError(t.file() + ": expected Table 4-2's 10 PM - 2 AM rows");
    const int frames = static_cast<int>(std::lround(scale.back().t_s / kFramePeriod_s)) + 1;
    writeDataset(c, out / "t4-2_moon_ephemeris", start, frames, fit::SkyEffects{},
                 [&](int f, float, float l1) {
                     return static_cast<float>(interpolate(scale, f * kFramePeriod_s)) * l1;
                 });
}

}  // namespace

int main(int argc, char** argv) {
    if (argc != 3) {
        std::fprintf(stderr, "usage: %s THESIS_CSV_DIR OUT_DIR\n", argv[0]);
        return 2;
    }
    try {
        const fs::path src = NVS_SOURCE_DIR;
        const DataDirs dirs{src / "config", fs::path(NVS_BINARY_DIR) / "nvstim-cache"};
        astro::Site site;
        site.lat_deg = 43.16856;
        site.lon_deg = -77.61583;
        site.height_m = kSiteHeight_m;
        sky::SkyModelConfig skyConfig;
        skyConfig.atmosphere.siteAltitude_m = kSiteHeight_m;
        skyConfig.atmosphere.visibility_km = kVisibility_km;
        Context c{dirs.config,
                  src / "scenarios" / "rit" / "scene.toml",
                  dirs,
                  [dirs](const fs::path& sc, const sensor::CameraParams& cam,
                         const fs::path& preset, const sensor::Overrides& settings) {
                      return rt::makeSceneStimulus(sc, cam, preset, settings, dirs);
                  },
                  astro::Ephemeris(site),
                  sky::SkyModel::create(skyConfig, dirs)};
        const fs::path thesis = argv[1], out = argv[2];
        std::printf("Table 8-2's night:\n");
        const std::vector<Row> k = table8_2Night(
            CsvTable::load(thesis / "table8-2_illuminance_timeline_make_adb.csv"), kNightStart, c);
        night8_2(c, k, out);
        lunarScattering8_3(c, k, thesis, out);
        ephemeris4_2(c, thesis, out);
    } catch (const std::exception& e) {
        std::fprintf(stderr, "nvs_thesis_scene_datasets: %s\n", e.what());
        return 2;
    }
    return 0;
}
