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

namespace nvs::sensor {

namespace {

// Reads a preset table with `--set` overrides taking precedence. Every override must name a
// parameter that the code reads; unused overrides are reported by finish().
class Reader {
  public:
    Reader(std::optional<ConfigTable> table, std::string prefix, const Overrides* ov,
           std::set<std::string>* used, FileLoc loc)
        : t_(std::move(table)),
          prefix_(std::move(prefix)),
          ov_(ov),
          used_(used),
          loc_(std::move(loc)) {}

    // A preset may leave out a whole table: its parameters keep their defaults.
    Reader sub(const std::string& key) const {
        std::optional<ConfigTable> t = t_ ? t_->optionalTable(key) : std::nullopt;
        return Reader(std::move(t), prefix_ + key + ".", ov_, used_, loc_);
    }

    template <typename T>
    T get(const std::string& key, const T& def) const {
        const T fromFile = t_ ? t_->get<T>(key, def) : def;  // marks the key read
        const std::string full = prefix_ + key;
        const auto it = ov_->find(full);
        if (it == ov_->end()) return fromFile;
        used_->insert(full);
        return parse<T>(full, it->second);
    }

    // Whether the preset file gives the key, and whether an override does.
    bool inFile(const std::string& key) const { return t_ && t_->contains(key); }
    bool overridden(const std::string& key) const { return ov_->count(prefix_ + key) != 0; }

    [[noreturn]] void fail(const std::string& key, const std::string& msg) const {
        const std::string full = prefix_ + key;
        if (ov_->count(full) != 0) throw SetupError("--set " + full + ": " + msg);
        if (t_) t_->fail(key, msg);
        throw SetupError(loc_, "key '" + full + "': " + msg);
    }

  private:
    template <typename T>
    static T parse(const std::string& key, const std::string& text) {
        // The value is parsed as TOML so that types behave as in the file.
        const std::string doc = "v = " + text + "\n";
        ConfigDocument d = [&] {
            try {
                return ConfigDocument::parseString(doc, "--set " + key);
            } catch (const SetupError&) {
                // Bare words are strings: --set agc=agc
                return ConfigDocument::parseString("v = \"" + text + "\"\n", "--set " + key);
            }
        }();
        try {
            return d.root().require<T>("v");
        } catch (const SetupError& e) {
            throw SetupError("--set " + key + "=" + text + ": " + e.what());
        }
    }

    std::optional<ConfigTable> t_;
    std::string prefix_;
    const Overrides* ov_;
    std::set<std::string>* used_;
    FileLoc loc_;
};

void require(bool ok, const Reader& r, const std::string& key, const std::string& msg) {
    if (!ok) r.fail(key, msg);
}

double positive(const Reader& r, const std::string& key, double def) {
    const double v = r.get<double>(key, def);
    require(std::isfinite(v) && v > 0.0, r, key, "must be > 0");
    return v;
}
double nonNegative(const Reader& r, const std::string& key, double def) {
    const double v = r.get<double>(key, def);
    require(std::isfinite(v) && v >= 0.0, r, key, "must be >= 0");
    return v;
}

CameraParams readCamera(const ConfigDocument& doc, const Overrides& ov, const FileLoc& loc,
                        const std::filesystem::path& baseDir) {
    std::set<std::string> used;
    const Reader root(doc.root(), "", &ov, &used, loc);
    CameraParams c;
    c.loc = loc;
    c.name = root.get<std::string>("name", loc.file);

    c.width = root.get<int>("width", c.width);
    c.height = root.get<int>("height", c.height);
    require(c.width > 0 && c.width <= 16384, root, "width", "must be in 1..16384");
    require(c.height > 0 && c.height <= 16384, root, "height", "must be in 1..16384");
    c.field_rate_Hz = positive(root, "field_rate_Hz", c.field_rate_Hz);
    c.gain_V = root.get<double>("gain_V", c.gain_V);
    require(c.gain_V >= 0.0 && c.gain_V <= 9.0, root, "gain_V", "must be in 0..9 V");
    const std::string agc = root.get<std::string>("agc", "off");
    if (agc == "off")
        c.agc = AgcMode::Off;
    else if (agc == "agc")
        c.agc = AgcMode::Agc;
    else if (agc == "abc")
        c.agc = AgcMode::Abc;
    else if (agc == "bsp")
        c.agc = AgcMode::Bsp;
    else if (agc == "autogate")
        c.agc = AgcMode::Autogate;
    else
        root.fail("agc", "must be off, agc, abc, bsp or autogate, not '" + agc + "'");
    c.f_number = positive(root, "f_number", c.f_number);

    const Reader optics = root.sub("optics");
    c.focal_length_mm = positive(optics, "focal_length_mm", c.focal_length_mm);
    c.optics_transmission = positive(optics, "transmission", c.optics_transmission);
    require(c.optics_transmission <= 1.0, optics, "transmission", "must be <= 1");
    c.cos4 = optics.get<bool>("cos4", c.cos4);
    c.optics_fill_factor = positive(optics, "fill_factor", c.optics_fill_factor);
    require(c.optics_fill_factor <= 1.0, optics, "fill_factor", "must be <= 1");
    const std::string sa = optics.get<std::string>("solid_angle", "lens");
    if (sa == "lens")
        c.solid_angle = SolidAngleModel::Lens;
    else if (sa == "ccd_area")
        c.solid_angle = SolidAngleModel::CcdArea;
    else
        optics.fail("solid_angle", "must be lens or ccd_area");

    const Reader spectral = root.sub("spectral");
    const std::string resp = spectral.get<std::string>("response_file", "");
    if (!resp.empty()) {
        std::filesystem::path p = resp;
        if (p.is_relative()) p = baseDir / p;
        if (!pathExists(p)) spectral.fail("response_file", "no file " + p.string());
        c.response_file = p;
    }
    c.response_column = spectral.get<std::string>("response_column", c.response_column);
    const bool qeFile = spectral.inFile("qe_peak"), qeSet = spectral.overridden("qe_peak");
    c.qe_peak = positive(spectral, "qe_peak", c.qe_peak);
    require(c.qe_peak <= 1.0, spectral, "qe_peak", "must be <= 1");
    c.monochromatic_nm = nonNegative(spectral, "monochromatic_nm", c.monochromatic_nm);

    const Reader gate = root.sub("gate");
    c.gate_s = nonNegative(gate, "gate_s", c.gate_s);
    c.gate_min_s = positive(gate, "gate_min_s", c.gate_min_s);

    const Reader pc = root.sub("photocathode");
    c.shot_noise = pc.get<bool>("shot_noise", c.shot_noise);
    c.ebi_lm_cm2 = nonNegative(pc, "ebi_lm_cm2", c.ebi_lm_cm2);
    const bool skFile = pc.inFile("luminous_sensitivity_uA_lm");
    const bool skSet = pc.overridden("luminous_sensitivity_uA_lm");
    c.cathode_sensitivity_uA_lm =
        nonNegative(pc, "luminous_sensitivity_uA_lm", c.cathode_sensitivity_uA_lm);
    // One of the two is the datasheet's; the other follows from it through the response.
    if (qeFile && skFile && !c.response_file.empty()) {
        pc.fail("luminous_sensitivity_uA_lm",
                "give either [spectral] qe_peak or the luminous sensitivity, not both: each "
                "follows from the other through the spectral response");
    }
    // The one given (an override wins over the file) is the source of the other.
    const bool qeIsSource = qeSet || (qeFile && !skSet);
    c.taper_magnification = positive(pc, "taper_magnification", c.taper_magnification);

    const Reader bsp = root.sub("bsp");
    c.bsp_knee_A = positive(bsp, "knee_A", c.bsp_knee_A);
    c.bsp_exponent = positive(bsp, "exponent", c.bsp_exponent);

    const Reader mcp = root.sub("mcp");
    c.mcp_enabled = mcp.get<bool>("enabled", c.mcp_enabled);
    const bool vcFile = mcp.inFile("crossover_V"), vcSet = mcp.overridden("crossover_V");
    c.mcp_crossover_V = positive(mcp, "crossover_V", c.mcp_crossover_V);
    c.luminous_gain_fL_fc = nonNegative(mcp, "luminous_gain_fL_fc", c.luminous_gain_fL_fc);
    c.luminous_gain_control_V =
        nonNegative(mcp, "luminous_gain_control_V", c.luminous_gain_control_V);
    if (vcFile && mcp.inFile("luminous_gain_fL_fc")) {
        mcp.fail("luminous_gain_fL_fc", "give either crossover_V or the luminous gain, not both");
    }
    if (vcSet && !mcp.overridden("luminous_gain_fL_fc")) c.luminous_gain_fL_fc = 0.0;  // Vc wins
    c.mcp_exponent = positive(mcp, "exponent", c.mcp_exponent);
    c.mcp_offset_V = mcp.get<double>("offset_V", c.mcp_offset_V);
    c.mcp_V_per_control_V = positive(mcp, "V_per_control_V", c.mcp_V_per_control_V);
    c.mcp_noise_factor = mcp.get<double>("noise_factor", c.mcp_noise_factor);
    require(c.mcp_noise_factor >= 1.0, mcp, "noise_factor", "F must be >= 1");
    c.mcp_noise = mcp.get<bool>("noise", c.mcp_noise);

    const Reader halo = root.sub("halo");
    c.halo_enabled = halo.get<bool>("enabled", c.halo_enabled);
    c.halo_fraction = nonNegative(halo, "fraction", c.halo_fraction);
    require(c.halo_fraction < 1.0, halo, "fraction", "must be below 1");
    c.halo_gap_um = positive(halo, "gap_um", c.halo_gap_um);
    c.halo_radius_um = nonNegative(halo, "radius_um", c.halo_radius_um);
    const Reader sat = root.sub("mcp_saturation");
    c.mcpsat_enabled = sat.get<bool>("enabled", c.mcpsat_enabled);
    c.mcpsat_pixel_charge_e = positive(sat, "pixel_charge_e", c.mcpsat_pixel_charge_e);
    c.mcpsat_recharge_s = positive(sat, "recharge_s", c.mcpsat_recharge_s);

    const Reader abc = root.sub("abc");
    c.abc_screen_limit_A = positive(abc, "screen_limit_A", c.abc_screen_limit_A);
    c.abc_time_constant_s = positive(abc, "time_constant_s", c.abc_time_constant_s);

    const Reader ph = root.sub("phosphor");
    c.phosphor_enabled = ph.get<bool>("enabled", c.phosphor_enabled);
    c.phosphor_type = ph.get<std::string>("type", c.phosphor_type);
    c.phosphor_decay_s = ph.get<std::vector<double>>("decay_s", c.phosphor_decay_s);
    c.phosphor_weight = ph.get<std::vector<double>>("weight", c.phosphor_weight);
    require(c.phosphor_decay_s.size() == c.phosphor_weight.size() && !c.phosphor_decay_s.empty() &&
                c.phosphor_decay_s.size() <= 4,
            ph, "weight", "decay_s and weight need the same length, 1..4");
    double wsum = 0.0;
    for (std::size_t i = 0; i < c.phosphor_weight.size(); ++i) {
        require(c.phosphor_decay_s[i] > 0.0, ph, "decay_s", "time constants must be > 0");
        require(c.phosphor_weight[i] >= 0.0, ph, "weight", "weights must be >= 0");
        wsum += c.phosphor_weight[i];
    }
    require(std::fabs(wsum - 1.0) < 1e-6, ph, "weight", "weights must sum to 1");
    c.screen_voltage_V = positive(ph, "screen_voltage_V", c.screen_voltage_V);
    c.screen_dead_voltage_V = nonNegative(ph, "dead_voltage_V", c.screen_dead_voltage_V);
    require(c.screen_dead_voltage_V < c.screen_voltage_V, ph, "dead_voltage_V",
            "must be below screen_voltage_V");
    c.phosphor_photons_per_eV = positive(ph, "photons_per_eV", c.phosphor_photons_per_eV);
    c.phosphor_peak_nm = positive(ph, "peak_nm", c.phosphor_peak_nm);
    c.phosphor_efficacy_lm_W = positive(ph, "efficacy_lm_W", c.phosphor_efficacy_lm_W);
    c.taper_transmission = positive(ph, "taper_transmission", c.taper_transmission);
    c.ccd_window_transmission = positive(ph, "ccd_window_transmission", c.ccd_window_transmission);
    c.ccd_qe = positive(ph, "ccd_qe", c.ccd_qe);
    c.ccd_fill_factor = positive(ph, "ccd_fill_factor", c.ccd_fill_factor);

    const Reader mtf = root.sub("mtf");
    c.mtf_enabled = mtf.get<bool>("enabled", c.mtf_enabled);
    c.ii_fc_cyc_mm = nonNegative(mtf, "ii_fc_cyc_mm", c.ii_fc_cyc_mm);
    c.ii_index = positive(mtf, "ii_index", c.ii_index);
    c.fibre_pitch_um = nonNegative(mtf, "fibre_pitch_um", c.fibre_pitch_um);
    c.ccd_aperture_mtf = mtf.get<bool>("ccd_aperture", c.ccd_aperture_mtf);
    c.digitiser_fc_cyc_mm = nonNegative(mtf, "digitiser_fc_cyc_mm", c.digitiser_fc_cyc_mm);
    c.digitiser_index = positive(mtf, "digitiser_index", c.digitiser_index);

    const Reader ccd = root.sub("ccd");
    c.pitch_x_um = positive(ccd, "pitch_x_um", c.pitch_x_um);
    c.pitch_y_um = positive(ccd, "pitch_y_um", c.pitch_y_um);
    c.full_well_e = nonNegative(ccd, "full_well_e", c.full_well_e);
    const std::string bl = ccd.get<std::string>("bloom", "vertical");
    if (bl == "off")
        c.bloom = BloomDirection::Off;
    else if (bl == "vertical")
        c.bloom = BloomDirection::Vertical;
    else if (bl == "horizontal")
        c.bloom = BloomDirection::Horizontal;
    else
        ccd.fail("bloom", "must be off, vertical or horizontal");
    c.smear_rel = nonNegative(ccd, "smear_rel", c.smear_rel);
    c.dark_e_s = nonNegative(ccd, "dark_e_s", c.dark_e_s);
    c.read_noise_e = nonNegative(ccd, "read_noise_e", c.read_noise_e);
    c.prnu_rel = nonNegative(ccd, "prnu_rel", c.prnu_rel);
    require(c.prnu_rel < 0.5, ccd, "prnu_rel", "must be < 0.5");

    const Reader video = root.sub("video");
    c.video_gain_dc_per_e = positive(video, "gain_dc_per_e", c.video_gain_dc_per_e);
    c.video_offset_dc = video.get<double>("offset_dc", c.video_offset_dc);
    c.video_noise_dc = nonNegative(video, "noise_dc", c.video_noise_dc);
    c.gamma = positive(video, "gamma", c.gamma);
    c.adc_bits = video.get<int>("adc_bits", c.adc_bits);
    require(c.adc_bits >= 1 && c.adc_bits <= 16, video, "adc_bits", "must be in 1..16");
    const std::string scan = video.get<std::string>("scan", "field");
    if (scan == "field")
        c.scan = ScanMode::Field;
    else if (scan == "frame")
        c.scan = ScanMode::Frame;
    else
        video.fail("scan", "must be field or frame");
    const std::string order = video.get<std::string>("field_order", "top");
    if (order != "top" && order != "bottom") video.fail("field_order", "must be top or bottom");
    c.topFieldFirst = order == "top";

    const Reader loop = root.sub("agc_loop");
    c.agc_target_dc = positive(loop, "target_dc", c.agc_target_dc);
    c.agc_time_constant_s = positive(loop, "time_constant_s", c.agc_time_constant_s);
    c.agc_lag_fields = loop.get<int>("lag_fields", c.agc_lag_fields);
    require(c.agc_lag_fields >= 0 && c.agc_lag_fields <= 7, loop, "lag_fields", "must be in 0..7");
    c.agc_min_gain_V = nonNegative(loop, "min_gain_V", c.agc_min_gain_V);
    c.agc_max_gain_V = positive(loop, "max_gain_V", c.agc_max_gain_V);
    require(c.agc_min_gain_V < c.agc_max_gain_V, loop, "max_gain_V", "must exceed min_gain_V");

    // Datasheet quantities → the model's: QE ↔ luminous sensitivity, and the MCP law's Vc from
    // the luminous gain at a control voltage.
    if (!c.response_file.empty() && c.monochromatic_nm <= 0.0) {
        const double perQe_uA_lm = luminousSensitivityPerQe_uA_lm(c, baseDir);
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
        c.mcp_crossover_V = vmRef / std::pow(gainRef, 1.0 / c.mcp_exponent);
    }

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

double CameraParams::mcpGain(double gainControl_V) const {
    if (!mcp_enabled) return 1.0;
    const double vm = mcp_offset_V + mcp_V_per_control_V * gainControl_V;
    if (vm <= 0.0) return 0.0;
    return std::pow(vm / mcp_crossover_V, mcp_exponent);
}

double CameraParams::controlVoltageForGain(double gain) const {
    if (!(gain > 0.0)) return 0.0;
    const double vm = mcp_crossover_V * std::pow(gain, 1.0 / mcp_exponent);
    return (vm - mcp_offset_V) / mcp_V_per_control_V;
}

double CameraParams::screenLumensPerBeamWatt() const {
    // P photons per eV of beam, each of energy hc/λ: the radiant efficiency P·hc/(λ·e).
    const double photon_J = kPlanck_J_s * kSpeedOfLight_m_s / (phosphor_peak_nm * 1e-9);
    return phosphor_photons_per_eV * photon_J / kElectronCharge_C * phosphor_efficacy_lm_W;
}

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

double CameraParams::ccdElectronsPerMcpElectron() const {
    if (!phosphor_enabled) return 1.0;
    // Eq. 6.2/6.3: N_CCD = (Vs − Vd)·P·T_fot·T_CCD·QE_CCD per electron striking the screen;
    // the CCD cell's fill factor takes its share of the light falling on it.
    return (screen_voltage_V - screen_dead_voltage_V) * phosphor_photons_per_eV *
           taper_transmission * ccd_window_transmission * ccd_qe * ccd_fill_factor;
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
