#pragma once
// Thermal camera preset: every parameter of the uncooled microbolometer chain
// (docs/bolometer.md), read from config/thermal_cameras/NAME.toml with strict keys (unknown
// keys are errors naming file:line:col) and `--set KEY=VALUE` overrides.
//
// Defaults live in code, each beside the stage that uses it (sim/bolometer/stages/*.h); a
// preset repeats the values it relies on with their sources.

#include <filesystem>
#include <string>

#include "sim/bolometer/reader.h"
#include "sim/bolometer/stages/adc.h"
#include "sim/bolometer/stages/agc.h"
#include "sim/bolometer/stages/detector.h"
#include "sim/bolometer/stages/focal_plane.h"
#include "sim/bolometer/stages/noise.h"
#include "sim/bolometer/stages/optics.h"
#include "sim/bolometer/stages/shutter.h"

namespace nvs::bolometer {

struct ThermalCameraParams : OpticsParams,
                             DetectorParams,
                             FocalPlaneParams,
                             NoiseParams,
                             ShutterParams,
                             AdcParams,
                             AgcParams {
    std::string name;
    FileLoc loc;  // where the preset came from

    // --- Format, timing and band ----------------------------------------------------------
    int width = 640;              // [px]
    int height = 512;             // [px]
    double frame_rate_Hz = 30.0;  // [Hz]
    double pitch_um = 12.0;       // [µm]
    double band_lo_um = 7.5;      // [µm] spectral band of the input radiance and the response
    double band_hi_um = 13.5;     // [µm]

    double framePeriod_s() const { return 1.0 / frame_rate_Hz; }
    double pixelArea_m2() const { return pitch_um * 1e-6 * pitch_um * 1e-6; }
    // Band radiance of a blackbody and its temperature derivative in this camera's band.
    double bandRadiance_W_m2_sr(double T_K) const;
    double bandRadianceDerivative_W_m2_sr_K(double T_K) const;
    // Power on a pixel's absorber per unit scene radiance [W per W m⁻² sr⁻¹] through a lens of
    // f-number N and transmission tau: P = τ·π/(1 + 4N²)·A·FF·L (the camera equation for a
    // finite cone, Vollmer & Möllmann, "Infrared Thermal Imaging", 2nd ed., Wiley-VCH 2018,
    // §2.4; the 1 + 4N² form is exact for an aplanatic lens, sin θ = 1/√(1 + 4N²)).
    double wattsPerRadiance(double fNumber, double tau) const;
    // The detector's output per kelvin of scene at T [V/K] through this camera's lens.
    double voltsPerSceneK(double T_K) const;
    // The temporal noise [V] that makes the datasheet's NETD: the NETD at its reference scene
    // temperature and f-number, with the camera's lens (Boson cores ship with their lens; the
    // datasheet's NETD is the camera's), times the response per kelvin there.
    double noiseVolts() const;
};

// Loads a preset: NAME (<configDir>/thermal_cameras/NAME.toml) or a path to a .toml file,
// applies the overrides, validates every value. Throws SetupError naming file:line:col or
// "--set KEY".
ThermalCameraParams loadThermalCamera(const std::filesystem::path& configDir,
                                      const std::string& nameOrPath,
                                      const Overrides& overrides = {});
// True for a thermal preset: NAME with a <configDir>/thermal_cameras/NAME.toml, or a .toml file
// in a folder named thermal_cameras (how a scenario's [camera] preset and `nvstim sensor
// --camera` tell the thermal camera from the intensified one).
bool isThermalPreset(const std::filesystem::path& configDir, const std::string& nameOrPath);
// The name of the preset's band in the files nvstim writes (the EXR header's nvstim.band of
// `nvstim render`), e.g. "LWIR 7.5-13.5 um": `nvstim sensor` takes a thermal render only into a
// camera of the same band.
std::string bandName(const ThermalCameraParams& cam);
// Parses preset text (for tests).
ThermalCameraParams parseThermalCamera(const std::string& text, const std::string& name,
                                       const Overrides& overrides = {});

}  // namespace nvs::bolometer
