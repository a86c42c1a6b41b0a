#include "sim/bolometer/camera.h"

#include <cstdio>
#include <set>

#include "sim/core/input_file.h"
#include "sim/core/planck.h"

namespace nvs::bolometer {

namespace {
constexpr double kPi = 3.14159265358979323846;

void readFormat(ThermalCameraParams& c, const Reader& r) {
    c.name = r.get<std::string>("name", c.name);
    c.width = r.get<int>("width", c.width);
    require(c.width >= 8 && c.width <= 8192, r, "width", "must be in 8 … 8192");
    c.height = r.get<int>("height", c.height);
    require(c.height >= 8 && c.height <= 8192, r, "height", "must be in 8 … 8192");
    c.frame_rate_Hz = positive(r, "frame_rate_Hz", c.frame_rate_Hz);
    c.pitch_um = positive(r, "pitch_um", c.pitch_um);
    c.band_lo_um = positive(r, "band_lo_um", c.band_lo_um);
    c.band_hi_um = positive(r, "band_hi_um", c.band_hi_um);
    require(c.band_hi_um > c.band_lo_um, r, "band_hi_um", "must be above band_lo_um");
}

ThermalCameraParams readCamera(const ConfigDocument& doc, const Overrides& ov, FileLoc loc) {
    ThermalCameraParams c;
    c.loc = loc;
    std::set<std::string> used;
    const Reader root(doc.root(), "", &ov, &used, loc);
    readFormat(c, root);
    c.OpticsParams::read(root);
    c.DetectorParams::read(root);
    c.FocalPlaneParams::read(root);
    c.NoiseParams::read(root);
    c.ShutterParams::read(root);
    c.AdcParams::read(root);
    c.AgcParams::read(root);
    // An FFC must end before the next is due, or the shutter would never open again.
    if (c.shutter_enabled && c.ffc_interval_s <= c.ffc_closed_frames * c.framePeriod_s())
        root.sub("shutter").fail("interval_s", "must exceed closed_frames / frame_rate_Hz");
    doc.finish();
    for (const auto& [key, value] : ov)
        if (used.count(key) == 0)
            throw SetupError("--set " + key + "=" + value + ": no such thermal camera parameter");
    return c;
}
}  // namespace

double ThermalCameraParams::bandRadiance_W_m2_sr(double T_K) const {
    return planckBandRadiance_W_m2_sr(band_lo_um, band_hi_um, T_K);
}
double ThermalCameraParams::bandRadianceDerivative_W_m2_sr_K(double T_K) const {
    return planckBandRadianceDerivative_W_m2_sr_K(band_lo_um, band_hi_um, T_K);
}
double ThermalCameraParams::wattsPerRadiance(double fNumber, double tau) const {
    return tau * kPi / (1.0 + 4.0 * fNumber * fNumber) * pixelArea_m2() * fill_factor;
}
double ThermalCameraParams::voltsPerSceneK(double T_K) const {
    return responsivity_V_W * wattsPerRadiance(f_number, optics_transmission) *
           bandRadianceDerivative_W_m2_sr_K(T_K);
}
double ThermalCameraParams::noiseVolts() const {
    return netd_K * responsivity_V_W * wattsPerRadiance(netd_f_number, optics_transmission) *
           bandRadianceDerivative_W_m2_sr_K(netd_reference_K);
}

ThermalCameraParams loadThermalCamera(const std::filesystem::path& configDir,
                                      const std::string& nameOrPath, const Overrides& overrides) {
    std::filesystem::path p = nameOrPath;
    if (p.extension() != ".toml" && nameOrPath.find('/') == std::string::npos)
        p = configDir / "thermal_cameras" / (nameOrPath + ".toml");
    if (!pathExists(p)) throw SetupError("--thermal-camera: no preset " + p.string());
    const ConfigDocument doc = ConfigDocument::parseFile(p);
    return readCamera(doc, overrides, FileLoc{p.string(), 0, 0});
}

bool isThermalPreset(const std::filesystem::path& configDir, const std::string& nameOrPath) {
    const std::filesystem::path p = nameOrPath;
    if (p.extension() == ".toml") return p.parent_path().filename() == "thermal_cameras";
    return pathExists(configDir / "thermal_cameras" / (nameOrPath + ".toml"));
}

std::string bandName(const ThermalCameraParams& cam) {
    char b[96];
    std::snprintf(b, sizeof b, "LWIR %.6g-%.6g um", cam.band_lo_um, cam.band_hi_um);
    return b;
}

ThermalCameraParams parseThermalCamera(const std::string& text, const std::string& name,
                                       const Overrides& overrides) {
    const ConfigDocument doc = ConfigDocument::parseString(text, name);
    return readCamera(doc, overrides, FileLoc{name, 0, 0});
}

}  // namespace nvs::bolometer
