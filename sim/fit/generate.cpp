#include "sim/fit/generate.h"

#include <algorithm>
#include <cmath>
#include <random>

#include "sim/core/error.h"
#include "sim/core/gamma_table.h"
#include "sim/fit/conv.h"
#include "sim/fit/effect_registry.h"
#include "sim/fit/engine.h"
#include "sim/fit/text.h"
#include "sim/sensor/chain.h"

namespace nvs::fit {

const std::vector<EffectRange>& effectRanges() {
    static const std::vector<EffectRange> r = {
        {"phosphor_persistence", "weight", 0.08, 0.3},
        {"phosphor_persistence", "decay_s", 0.025, 0.1},
        {"halo", "fraction", 0.08, 0.2},
        {"halo", "radius_um", 90.0, 200.0},
        {"fixed_pattern_noise", "prnu_rel", 0.045, 0.1},
        {"mcp_saturation", "peak_over_charge", 2.0, 5.0},
        {"bright_source_protection", "knee_over_median_current", 0.7, 2.0},
        {"veiling_glare", "fraction", 0.08, 0.2},
        {"veiling_glare", "scale_um", 250.0, 600.0},
        {"vertical_smear", "smear_rel", 0.05, 0.12},
        // 3–10 DC of dark signal at 4 V: the cathode's luminous sensitivity follows from the
        // pinned QE 0.25 (1230 µA/lm), so the EBI that makes it is 1800/1230 × the range first
        // set with an 1800 µA/lm cathode (5e-10–1.5e-9).
        {"ebi_background", "ebi_lm_cm2", 7.3e-10, 2.2e-9},
        {"excess_noise", "noise_factor_ratio", 1.3, 1.8},
    };
    return r;
}

namespace {

double draw(std::mt19937_64& rng, const char* effect, const char* parameter) {
    for (const EffectRange& e : effectRanges())
        if (std::string(e.effect) == effect && std::string(e.parameter) == parameter) {
            const double u = std::uniform_real_distribution<double>(0.0, 1.0)(rng);
            return e.lo + u * (e.hi - e.lo);
        }
    throw SetupError(std::string("no range for ") + effect + "." + parameter);
}

// The model under test: the thesis camera at the spec's size, lacking the hidden effects.
sensor::Overrides baseOverrides(const GenSpec& s) {
    return {{"width", std::to_string(s.width)},
            {"height", std::to_string(s.height)},
            {"phosphor.decay_s", "[1.0e-4]"},
            {"phosphor.weight", "[1.0]"},
            {"ccd.prnu_rel", "0.0"},
            {"ccd.smear_rel", "0.0"},
            {"photocathode.ebi_lm_cm2", "0.0"},
            {"agc", "\"off\""},
            {"gain_V", "4.0"},
            {"ccd.full_well_e", "0.0"},
            // The chain's own halo and MCP saturation off: the model without the effects the
            // sweep hides. The tube as Table 18-6's radiance calibration has it (peak QE 0.25,
            // Vc 520 V, eq. 6.1 without a ceiling, every photoelectron detected, Table 18-6's
            // 0.003738 DC/e, 50 e read noise, no video noise), on which the sweep's ranges were
            // set.
            {"halo.enabled", "false"},
            {"mcp_saturation.enabled", "false"},
            {"mcp.crossover_V", "520.0"},
            {"mcp.gain_max", "0"},
            {"mcp.plate_max_V", "0"},
            {"mcp.detection_efficiency", "1"},
            {"video.gain_dc_per_e", "0.003738"},
            {"ccd.read_noise_e", "50.0"},
            {"spectral.qe_peak", "0.25"},
            {"video.noise_dc", "0.0"}};
}

// DC above offset per unit Lpe on the axis, from the mean chain.
double dcPerLpe(const sensor::CameraParams& cam, const std::filesystem::path& configDir,
                GammaTableCache& tables) {
    sensor::CameraParams c = cam;
    c.shot_noise = c.mcp_noise = false;
    c.read_noise_e = 0.0;
    c.width = c.height = 32;
    ImageF in(32, 32);
    in.fill(1e12f);
    sensor::IiccdChain chain(c, 0, configDir, tables);
    for (int k = 0; k < 4; ++k)
        chain.process(in.cview());
    return chain.electrons()(16, 16) * c.video_gain_dc_per_e / 1e12;
}

// One stimulus block in DC above offset (before the effects): a dim background with a gradient,
// panels from dim to bright (a range of signal for photon transfer, column contrast for smear),
// bright points (halo, saturation), all scaled by the block's overall brightness.
void drawScene(std::mt19937_64& rng, int w, int h, Plane& out) {
    std::uniform_real_distribution<double> U(0.0, 1.0);
    const double g = std::exp(std::log(0.6) + U(rng) * std::log(1.6 / 0.6));  // 0.6 .. 1.6
    const double bg = 2.0 + 10.0 * U(rng), gx = U(rng) - 0.5, gy = U(rng) - 0.5;
    out.assign(static_cast<std::size_t>(w) * h, 0.0f);
    for (int y = 0; y < h; ++y)
        for (int x = 0; x < w; ++x)
            out[static_cast<std::size_t>(y) * w + x] = static_cast<float>(
                bg * (1.0 + 0.8 * gx * (x - w / 2.0) / w + 0.8 * gy * (y - h / 2.0) / h));
    for (int p = 0; p < 4; ++p) {
        const int x0 = static_cast<int>(U(rng) * w * 0.75);
        const int y0 = static_cast<int>(U(rng) * h * 0.6);
        const int pw = 5 + static_cast<int>(U(rng) * w * 0.2);
        const int ph = 10 + static_cast<int>(U(rng) * h * 0.4);
        const double lv = 10.0 + 110.0 * U(rng);
        for (int y = y0; y < std::min(h, y0 + ph); ++y)
            for (int x = x0; x < std::min(w, x0 + pw); ++x)
                out[static_cast<std::size_t>(y) * w + x] = static_cast<float>(lv);
    }
    for (int p = 0; p < 5; ++p) {
        const double cx = 8 + U(rng) * (w - 16), cy = 8 + U(rng) * (h - 16);
        const double amp = 200.0 + 400.0 * U(rng);
        for (int y = 0; y < h; ++y)
            for (int x = 0; x < w; ++x)
                if (std::hypot(x - cx, y - cy) <= 1.6)
                    out[static_cast<std::size_t>(y) * w + x] += static_cast<float>(amp);
    }
    for (float& v : out)
        v = static_cast<float>(v * g);
}

bool has(const GenSpec& s, const char* e) {
    return std::find(s.effects.begin(), s.effects.end(), e) != s.effects.end();
}

}  // namespace

namespace {

// Spreads a fraction of each scene with a kernel (halo, veiling glare), in place.
void spreadScenes(std::vector<Plane>& scenes, Convolver& conv, double frac,
                  const std::function<double(double)>& kernel) {
    std::vector<Plane> K;
    conv.setFrames(scenes);
    conv.convolve(kernel, K);
    for (std::size_t i = 0; i < scenes.size(); ++i)
        for (std::size_t p = 0; p < scenes[i].size(); ++p)
            scenes[i][p] = static_cast<float>((1.0 - frac) * scenes[i][p] + frac * K[i][p]);
}

// The effects diagnose models itself, applied to the light (DC above offset) before the chain.
void stimulusEffects(const GenSpec& s, const sensor::CameraParams& cam, std::mt19937_64& rng,
                     std::vector<Plane>& scenes, Generated& g) {
    const double px = cam.pitch_x_um * cam.taper_magnification;
    Convolver conv(s.width, s.height, px, cam.pitch_y_um * cam.taper_magnification);
    if (has(s, "halo")) {
        const double f = draw(rng, "halo", "fraction"), r = draw(rng, "halo", "radius_um");
        spreadScenes(scenes, conv, f, ringKernel(r, px));
        g.truth["halo.fraction"] = f;
        g.truth["halo.radius_um"] = r;
    }
    if (has(s, "veiling_glare")) {
        const double f = draw(rng, "veiling_glare", "fraction");
        const double sc = draw(rng, "veiling_glare", "scale_um");
        spreadScenes(scenes, conv, f, expKernel(sc));
        g.truth["veiling_glare.fraction"] = f;
        g.truth["veiling_glare.scale_um"] = sc;
    }
    if (has(s, "mcp_saturation")) {
        double peak = 0.0;
        for (const Plane& p : scenes)
            for (float v : p)
                peak = std::max(peak, static_cast<double>(v));
        const double q = peak / draw(rng, "mcp_saturation", "peak_over_charge");
        for (Plane& p : scenes)
            for (float& v : p)
                v = static_cast<float>(-q * std::expm1(-v / q));
        g.truth["mcp_saturation.pixel_charge_e"] =
            q / (cam.ccdElectronsPerMcpElectron() * cam.video_gain_dc_per_e);
    }
}

// The chain's own effects, as preset overrides of the camera that makes the frames.
sensor::Overrides chainEffects(const GenSpec& s, const Dataset& d, std::mt19937_64& rng,
                               const std::filesystem::path& configDir, GammaTableCache& tables,
                               Generated& g) {
    sensor::Overrides ov = d.settings;
    if (has(s, "phosphor_persistence")) {
        const double w = draw(rng, "phosphor_persistence", "weight");
        const double tau = draw(rng, "phosphor_persistence", "decay_s");
        ov["phosphor.decay_s"] = "[1.0e-4, " + tomlNumber(tau) + "]";
        ov["phosphor.weight"] = "[" + tomlNumber(1.0 - w) + ", " + tomlNumber(w) + "]";
        g.truth["phosphor_persistence.weight"] = w;
        g.truth["phosphor_persistence.decay_s"] = tau;
    }
    if (has(s, "fixed_pattern_noise")) {
        const double p = draw(rng, "fixed_pattern_noise", "prnu_rel");
        ov["ccd.prnu_rel"] = tomlNumber(p);
        g.truth["fixed_pattern_noise.prnu_rel"] = p;
    }
    if (has(s, "vertical_smear")) {
        const double p = draw(rng, "vertical_smear", "smear_rel");
        ov["ccd.smear_rel"] = tomlNumber(p);
        g.truth["vertical_smear.smear_rel"] = p;
    }
    if (has(s, "ebi_background")) {
        const double p = draw(rng, "ebi_background", "ebi_lm_cm2");
        ov["photocathode.ebi_lm_cm2"] = tomlNumber(p);
        g.truth["ebi_background.ebi_lm_cm2"] = p;
    }
    if (has(s, "excess_noise")) {
        const double F =
            d.camera.mcp_noise_factor * draw(rng, "excess_noise", "noise_factor_ratio");
        ov["mcp.noise_factor"] = tomlNumber(F);
        g.truth["excess_noise.noise_factor"] = F;
    }
    // Registered effects (effect_registry.h): their parameters drawn in their hidden ranges,
    // switched on in the chain by their own preset keys.
    for (const RegisteredEffect* e : registeredEffects()) {
        if (!has(s, e->name)) continue;
        std::vector<double> p;
        for (const EffectParameter& ep : e->parameters) {
            p.push_back(std::uniform_real_distribution<double>(ep.hideLo, ep.hideHi)(rng));
            g.truth[std::string(e->name) + "." + ep.name] = p.back();
        }
        for (const auto& [k, v] : registeredPresetKeys(*e, p))
            ov[k] = v;
    }
    if (has(s, "bright_source_protection")) {
        std::vector<double> I;
        sensor::CameraParams c = d.camera;
        c.shot_noise = c.mcp_noise = false;
        for (const ImageF& st : d.stimuli) {
            sensor::IiccdChain chain(c, 0, configDir, tables);
            I.push_back(chain.process(st.cview()).cathode_current_A);
        }
        std::sort(I.begin(), I.end());
        const double knee =
            I[I.size() / 2] * draw(rng, "bright_source_protection", "knee_over_median_current");
        ov["agc"] = "\"bsp\"";
        ov["bsp.knee_A"] = tomlNumber(knee);
        g.truth["bright_source_protection.knee_A"] = knee;
    }
    return ov;
}

}  // namespace

void makeFrames(const sensor::CameraParams& cam, std::uint64_t seed,
                const std::vector<ImageF>& seen, const std::filesystem::path& configDir,
                Dataset& d) {
    GammaTableCache tables;
    sensor::IiccdChain chain(cam, seed, configDir, tables);
    for (int f : d.stimulusOfFrame) {
        chain.process(seen[static_cast<std::size_t>(f)].cview());
        Plane p(static_cast<std::size_t>(d.width) * d.height);
        for (int y = 0; y < d.height; ++y)
            for (int x = 0; x < d.width; ++x)
                p[static_cast<std::size_t>(y) * d.width + x] = chain.video()(x, y);
        d.frames.push_back(std::move(p));
    }
}

Generated generate(const GenSpec& s, const std::filesystem::path& configDir) {
    for (const std::string& e : s.effects) {
        const auto& ranges = effectRanges();
        if (std::any_of(ranges.begin(), ranges.end(),
                        [&](const EffectRange& r) { return e == r.effect; }) ||
            findRegistered(e) != nullptr)
            continue;
        std::string known;
        for (const EffectRange& r : ranges)
            if (known.find(r.effect) == std::string::npos)
                known += (known.empty() ? "" : ", ") + std::string(r.effect);
        for (const RegisteredEffect* r : registeredEffects())
            known += std::string(", ") + r->name;
        throw SetupError("unknown effect '" + e + "' to hide (known: " + known + ")");
    }
    Generated g;
    Dataset& d = g.data;
    std::mt19937_64 rng(s.seed * 0x9E3779B97F4A7C15ull + 0x1234567ull);
    d.preset = "pulnix-ag5745ef3";
    d.settings = baseOverrides(s);
    d.camera = loadModelCamera(configDir, d.preset, d.settings, d.cameraExtra);
    d.presetFile = sensor::resolveCameraPath(configDir, d.preset);
    d.width = s.width;
    d.height = s.height;
    d.frameRate_Hz = 1.0 / d.camera.integrationPeriod_s();
    d.frameMax_dc = (1 << d.camera.adc_bits) - 1;
    d.unit = "pe/s/m2/sr";
    GammaTableCache tables;
    const double k = dcPerLpe(d.camera, configDir, tables);
    std::vector<Plane> scenes(static_cast<std::size_t>(s.stimuli));
    for (Plane& p : scenes)
        drawScene(rng, s.width, s.height, p);
    // The dataset holds the stimulus as the scene gave it; the camera that makes the frames
    // sees it through the effects diagnose models itself.
    std::vector<Plane> seen = scenes;
    stimulusEffects(s, d.camera, rng, seen, g);
    std::vector<ImageF> seenLpe;
    auto toLpe = [&](const Plane& p) {
        ImageF img(s.width, s.height);
        for (int y = 0; y < s.height; ++y)
            for (int x = 0; x < s.width; ++x)
                img(x, y) = static_cast<float>(
                    std::max(0.0, p[static_cast<std::size_t>(y) * s.width + x] / k));
        return img;
    };
    for (std::size_t i = 0; i < scenes.size(); ++i) {
        d.stimuli.push_back(toLpe(scenes[i]));
        seenLpe.push_back(toLpe(seen[i]));
    }
    for (int b = 0; b < s.stimuli; ++b)
        for (int j = 0; j < s.hold; ++j)
            d.stimulusOfFrame.push_back(b);
    const sensor::Overrides ov = chainEffects(s, d, rng, configDir, tables, g);
    FitEffects unused;
    const sensor::CameraParams cam = loadModelCamera(configDir, d.preset, ov, unused);
    makeFrames(cam, s.seed, seenLpe, configDir, d);
    return g;
}

}  // namespace nvs::fit
