#include "sim/sensor/camera.h"

#include <cmath>
#include <fstream>
#include <optional>
#include <set>
#include <sstream>

#include "sim/core/config.h"
#include "sim/core/csv.h"
#include "sim/core/input_file.h"
#include "sim/core/photometry.h"
#include "sim/core/planck.h"
#include "sim/core/units.h"
#include "sim/sensor/preset_reader.h"

namespace nvs::sensor {

namespace {

// The preset's own keys: its name and the format every stage shares.
void readFormat(const PresetReader& root, CameraParams& c) {
    c.name = root.get<std::string>("name", root.loc().file);
    c.width = root.get<int>("width", c.width);
    c.height = root.get<int>("height", c.height);
    require(c.width > 0 && c.width <= 16384, root, "width", "must be in 1..16384");
    require(c.height > 0 && c.height <= 16384, root, "height", "must be in 1..16384");
    c.field_rate_Hz = positive(root, "field_rate_Hz", c.field_rate_Hz);
}

// Each part of the preset, read by the Params struct of the stage that uses it, in this order.
template <class Params>
void readPart(const PresetReader& root, CameraParams& c) {
    static_cast<Params&>(c).read(root);
}
using ReadPart = void (*)(const PresetReader&, CameraParams&);
constexpr ReadPart kParts[] = {
    readFormat,
    readPart<ControlParams>,  // gain_V, agc, [abc], [agc_loop]
    readPart<OpticsParams>,
    readPart<PhotocathodeParams>,  // [spectral], [photocathode]
    readPart<GateParams>,
    readPart<McpParams>,  // [bsp], [mcp], [mcp_saturation]
    readPart<HaloParams>,
    readPart<PhosphorParams>,
    readPart<BlurParams>,
    readPart<CcdParams>,
    readPart<VideoParams>,
};

// Datasheet quantities → the model's: QE ↔ luminous sensitivity, and the MCP law's Vc from the
// luminous gain at a control voltage.
void deriveFromDatasheet(const PresetReader& root, CameraParams& c) {
    const PresetReader spectral = root.sub("spectral");
    const PresetReader pc = root.sub("photocathode");
    const PresetReader mcp = root.sub("mcp");
    if (!c.response_file.empty() && c.monochromatic_nm <= 0.0) {
        // The one given (an override wins over the file) is the source of the other.
        const bool qeIsSource =
            spectral.overridden("qe_peak") ||
            (spectral.inFile("qe_peak") && !pc.overridden("luminous_sensitivity_uA_lm"));
        const double perQe_uA_lm = luminousSensitivityPerQe_uA_lm(c, root.baseDir());
        if (qeIsSource) {
            c.cathode_sensitivity_uA_lm = c.qe_peak * perQe_uA_lm;
        } else {
            c.qe_peak = c.cathode_sensitivity_uA_lm / perQe_uA_lm;
            require(c.qe_peak > 0.0 && c.qe_peak <= 1.0, pc, "luminous_sensitivity_uA_lm",
                    "implies a peak QE of " + std::to_string(c.qe_peak) + ", outside (0, 1]");
        }
    }
    if (c.luminous_gain_fL_fc > 0.0 && c.mcp_enabled) {
        const double perMcpGain = c.luminousGain_fL_fc(-1.0);  // fL/fc per unit MCP gain
        require(perMcpGain > 0.0, mcp, "luminous_gain_fL_fc",
                "needs the cathode's luminous sensitivity and the screen's efficiency");
        const double gainRef = c.luminous_gain_fL_fc / perMcpGain;
        const double vmRef = c.mcp_offset_V + c.mcp_V_per_control_V * c.luminous_gain_control_V;
        require(vmRef > 0.0, mcp, "luminous_gain_control_V", "gives no MCP voltage");
        require(!(c.mcp_gain_max > 0.0) ||
                    gainRef / c.mcp_detection_efficiency < 0.999 * c.mcp_gain_max,
                mcp, "luminous_gain_fL_fc", "needs an MCP gain at or above mcp.gain_max");
        c.mcp_crossover_V = c.crossoverForGain(gainRef, c.luminous_gain_control_V);
    }
}

CameraParams readCamera(const ConfigDocument& doc, const Overrides& ov, const FileLoc& loc,
                        const std::filesystem::path& baseDir) {
    std::set<std::string> used;
    const PresetReader root(doc.root(), "", &ov, &used, loc, baseDir);
    CameraParams c;
    c.loc = loc;
    for (const ReadPart read : kParts)
        read(root, c);
    deriveFromDatasheet(root, c);

    doc.finish();
    for (const auto& [key, value] : ov) {
        if (used.count(key) == 0) {
            throw SetupError("--set " + key + "=" + value + ": unknown camera parameter '" + key +
                             "'");
        }
    }
    return c;
}

}  // namespace

double CameraParams::luminousGain_fL_fc(double gainControl_V) const {
    // Per lumen on the cathode: S_k amperes of photocurrent, G·S_k out of the MCP, each electron
    // landing with (Va − Vd) eV of useful energy; gainControl_V < 0: per unit MCP gain.
    const double g = gainControl_V < 0.0 ? 1.0 : mcpGain(gainControl_V);
    return cathode_sensitivity_uA_lm * 1e-6 * g * (screen_voltage_V - screen_dead_voltage_V) *
           screenLumensPerBeamWatt();
}

double luminousSensitivityPerQe_uA_lm(const CameraParams& cam,
                                      const std::filesystem::path& configDir) {
    // A 2856 K (CIE illuminant A) source, as photocathodes are specified: the photocurrent per
    // lumen, q·∫QE(λ)·λ/(hc)·P(λ)dλ / (K_m∫V(λ)P(λ)dλ), for a QE of peak 1.
    const Spectrum a = planckRadiance_W_m2_sr_nm(2856.0);
    const Spectrum photonsPerJ = Spectrum::fromFunction(
        [](double nm) { return nm * 1e-9 / (kPlanck_J_s * kSpeedOfLight_m_s); });
    const double pe = integrateProduct_nm(a * cameraResponse(cam), photonsPerJ);
    const double lm = Photometry(configDir).photometricIntegral(a);
    return kElectronCharge_C * pe / lm * 1e6;
}

double CameraParams::peRatePerLpe_on_axis() const {
    // Step 1 (docs/sensor.md): an on-axis pixel of area A at the cathode behind a lens of
    // f-number N collects E = L·τ·π/(4N²) (camera equation, object at infinity), so
    // ṅ = Lpe·τ·π/(4N²)·A. The thesis's eq. 6.25 used Ω = A_CCD/f² instead.
    double omega_sr = kPi / (4.0 * f_number * f_number);
    if (solid_angle == SolidAngleModel::CcdArea) {
        const double areaCcd_m2 = width * pitch_x_um * 1e-6 * height * pitch_y_um * 1e-6;
        const double f_m = focal_length_mm * 1e-3;
        omega_sr = areaCcd_m2 / (f_m * f_m);
    }
    return optics_transmission * omega_sr * pixelAreaAtCathode_m2() * optics_fill_factor;
}

std::filesystem::path resolveCameraPath(const std::filesystem::path& configDir,
                                        const std::string& nameOrPath) {
    std::filesystem::path p = nameOrPath;
    if (p.extension() == ".toml" || nameOrPath.find('/') != std::string::npos) {
        if (!pathExists(p)) throw SetupError("--camera: no file " + p.string());
        return p;
    }
    const std::filesystem::path q = configDir / "cameras" / (nameOrPath + ".toml");
    if (!pathExists(q)) {
        std::string names;
        if (isDirectory(configDir / "cameras")) {
            for (const auto& e : std::filesystem::directory_iterator(configDir / "cameras")) {
                if (e.path().extension() == ".toml") names += " " + e.path().stem().string();
            }
        }
        throw SetupError("--camera " + nameOrPath + ": no preset " + q.string() +
                         " (presets:" + names + ")");
    }
    return q;
}

CameraParams loadCamera(const std::filesystem::path& configDir, const std::string& nameOrPath,
                        const Overrides& overrides) {
    const std::filesystem::path p = resolveCameraPath(configDir, nameOrPath);
    const ConfigDocument doc = ConfigDocument::parseFile(p);
    // Data files named by a preset are relative to config/.
    std::filesystem::path base = p.parent_path().parent_path();
    if (!pathExists(base / "spectra")) base = configDir;
    return readCamera(doc, overrides, FileLoc{p.string(), 0, 0}, base);
}

CameraParams parseCamera(const std::filesystem::path& configDir, const std::string& text,
                         const std::string& name, const Overrides& overrides) {
    const ConfigDocument doc = ConfigDocument::parseString(text, name);
    return readCamera(doc, overrides, FileLoc{name, 0, 0}, configDir);
}

Overrides parseOverrides(const std::vector<std::string>& args) {
    Overrides ov;
    for (const std::string& a : args) {
        const auto eq = a.find('=');
        if (eq == std::string::npos || eq == 0 || eq + 1 == a.size()) {
            throw SetupError("--set " + a + ": expected KEY=VALUE");
        }
        const std::string key = a.substr(0, eq);
        if (ov.count(key) != 0) throw SetupError("--set " + a + ": '" + key + "' set twice");
        ov[key] = a.substr(eq + 1);
    }
    return ov;
}

Spectrum cameraResponse(const CameraParams& cam) {
    if (cam.monochromatic_nm > 0.0) {
        Spectrum s;
        const int i = static_cast<int>(std::lround(cam.monochromatic_nm - SpectralGrid::kMin_nm));
        if (i >= 0 && i < SpectralGrid::kCount) s[i] = 1.0;  // a 1 nm wide line
        return s;
    }
    if (cam.response_file.empty()) {
        throw SetupError(cam.loc, "camera has no spectral.response_file; W/m2/sr input needs one");
    }
    TabulatedSpectrum t = loadSpectrumCsv(cam.response_file, "wavelength_*", cam.response_column);
    Spectrum s = t.resample(Extrapolation::Zero);
    const double peak = s.max();
    if (!(peak > 0.0)) throw SetupError(t.loc, "response curve is zero everywhere");
    s *= 1.0 / peak;
    return s;
}

Spectrum spectrumShape(const std::filesystem::path& configDir, const std::string& spec) {
    if (spec == "flat") return Spectrum(1.0);
    if (spec.rfind("blackbody:", 0) == 0) {
        char* end = nullptr;
        const double t = std::strtod(spec.c_str() + 10, &end);
        if (end == spec.c_str() + 10 || *end != '\0' || !(t > 100.0 && t < 100000.0)) {
            throw SetupError("--spectrum " + spec + ": expected blackbody:T with T in K");
        }
        return planckRadiance_W_m2_sr_nm(t);
    }
    if (spec == "moon" || spec == "night_sky") {
        // Tabulated spectra in config/spectra when present; otherwise documented blackbody
        // stand-ins: moonlight ≈ reflected sunlight (5800 K shape, lunar reddening ignored);
        // night sky (airglow + starlight) is red-rich, approximated by 2000 K.
        const std::filesystem::path p = configDir / "spectra" / (spec + "_shape.csv");
        if (pathExists(p)) {
            return loadSpectrumCsv(p, "wavelength_nm", "radiance_rel").resample();
        }
        return planckRadiance_W_m2_sr_nm(spec == "moon" ? 5800.0 : 2000.0);
    }
    throw SetupError("--spectrum " + spec + ": expected flat, blackbody:T, moon or night_sky");
}

double peRadiancePerBandRadiance(const CameraParams& cam, const Spectrum& shape,
                                 const Spectrum& bandWeight) {
    const Spectrum beta = cameraResponse(cam);
    // photons per joule at λ: λ/(hc)
    const Spectrum photonsPerJ = Spectrum::fromFunction(
        [](double nm) { return nm * 1e-9 / (kPlanck_J_s * kSpeedOfLight_m_s); });
    const double pe = integrateProduct_nm(shape * beta * cam.qe_peak, photonsPerJ);
    const double band = integrateProduct_nm(shape, bandWeight);
    if (!(band > 0.0)) throw SetupError(cam.loc, "spectrum has no energy in the camera band");
    return pe / band;
}

double peRadiancePerBandRadiance(const std::filesystem::path& configDir, const CameraParams& cam,
                                 const std::string& spectrumSpec) {
    if (cam.monochromatic_nm > 0.0) {
        // Thesis eq. 6.25: every joule is counted as photons of one wavelength.
        return cam.qe_peak * cam.monochromatic_nm * 1e-9 / (kPlanck_J_s * kSpeedOfLight_m_s);
    }
    return peRadiancePerBandRadiance(cam, spectrumShape(configDir, spectrumSpec),
                                     cameraResponse(cam));
}

}  // namespace nvs::sensor
