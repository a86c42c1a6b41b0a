#pragma once
// Camera preset: every parameter of the IICCD chain (docs/design.md §4.5), read from
// config/cameras/NAME.toml with strict keys (unknown keys are errors naming file:line:col) and
// `--set KEY=VALUE` overrides (an override naming no parameter is an error naming the argument).
//
// Defaults live in code, each beside the stage that uses it (sim/sensor/stages/*.h). Each field
// states its unit in its name or comment and the source of its default; a preset file repeats the
// parameters it relies on with their sources.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sim/core/spectrum.h"
#include "sim/sensor/control.h"
#include "sim/sensor/stages/blur.h"
#include "sim/sensor/stages/ccd.h"
#include "sim/sensor/stages/gate.h"
#include "sim/sensor/stages/halo.h"
#include "sim/sensor/stages/mcp.h"
#include "sim/sensor/stages/optics.h"
#include "sim/sensor/stages/phosphor.h"
#include "sim/sensor/stages/photocathode.h"
#include "sim/sensor/stages/video.h"

namespace nvs::sensor {

// Every stage's parameters (each Params struct beside the stage that uses it, reading its own
// tables of the preset) and the format they share.
struct CameraParams : OpticsParams,
                      GateParams,
                      PhotocathodeParams,
                      HaloParams,
                      McpParams,
                      PhosphorParams,
                      BlurParams,
                      CcdParams,
                      VideoParams,
                      ControlParams {
    std::string name;
    FileLoc loc;  // where the preset came from

    // --- Format and timing -------------------------------------------------------------------
    int width = 768;               // [px] Appendix A Table 11-2: 768 (H)
    int height = 494;              // [px] 493 active lines (Table 11-2), even for two fields
    double field_rate_Hz = 59.94;  // [Hz] 525 lines 60 Hz 2:1 interlace (Table 11-2)

    // Derived
    double fieldPeriod_s() const { return 1.0 / field_rate_Hz; }
    // Field scan: the parity of the rows field k reads out (0: even rows).
    int fieldRowParity(std::uint64_t field) const {
        return static_cast<int>(field & 1u) ^ (topFieldFirst ? 0 : 1);
    }
    // The time one output image integrates: a field, or a frame (two fields).
    double integrationPeriod_s() const {
        return scan == ScanMode::Field ? fieldPeriod_s() : 2.0 * fieldPeriod_s();
    }
    double pixelAreaAtCathode_m2() const {
        return pitch_x_um * 1e-6 * taper_magnification * pitch_y_um * 1e-6 * taper_magnification;
    }
    // Luminous gain of the tube at a control voltage [fL/fc = lm out per lm in]: cathode
    // sensitivity · MCP gain · (Va − Vd) · screen lm/W (2856 K input, as tubes are specified).
    double luminousGain_fL_fc(double gainControl_V) const;
    // Mean output [DC above the offset] per photoelectron at a control voltage: the MCP gain,
    // screen, fibre and CCD conversion and the video gain (photon transfer's K; the MCP's
    // excess noise factor F = mcp_noise_factor comes on top for the variance).
    double dcPerPhotoelectron(double gainControl_V) const {
        return mcpGain(gainControl_V) * ccdElectronsPerMcpElectron() * video_gain_dc_per_e;
    }
    // Photoelectrons per second per pixel per unit Lpe [pe s⁻¹ m⁻² sr⁻¹] on axis (step 1).
    double peRatePerLpe_on_axis() const;
};

// KEY=VALUE overrides from the command line. Keys are dotted preset paths ("mcp.noise_factor").
using Overrides = std::map<std::string, std::string>;

// Loads a preset: NAME (<configDir>/cameras/NAME.toml) or a path to a .toml file, applies the
// overrides, validates every value. Data files it names are relative to the config folder
// above the preset's folder, else to configDir. Throws SetupError naming file:line:col or
// "--set KEY".
CameraParams loadCamera(const std::filesystem::path& configDir, const std::string& nameOrPath,
                        const Overrides& overrides = {});
// Parses preset text (for tests); data files relative to configDir.
CameraParams parseCamera(const std::filesystem::path& configDir, const std::string& text,
                         const std::string& name, const Overrides& overrides = {});
// Resolves NAME or PATH to a preset file path (throws if absent).
std::filesystem::path resolveCameraPath(const std::filesystem::path& configDir,
                                        const std::string& nameOrPath);

// Parses "KEY=VALUE" arguments; throws SetupError naming the argument.
Overrides parseOverrides(const std::vector<std::string>& args);

// Input unit conversion for band-integrated radiance images (docs/design.md §3, §7).
// Lpe = Lband · ∫ s(λ) QE(λ) λ/(hc) dλ / ∫ s(λ) β(λ) dλ, with s the source spectrum shape,
// Luminous sensitivity [µA/lm, 2856 K] of the camera's photocathode for a peak QE of 1: the
// factor between the datasheet's sensitivity and qe_peak (V(λ) from configDir/spectra).
double luminousSensitivityPerQe_uA_lm(const CameraParams& cam,
                                      const std::filesystem::path& configDir);

// QE = qe_peak·β (the relative response of the camera), β the same response used to
// integrate the band radiance. Spectrum spec: flat | blackbody:T | moon | night_sky (the last
// two from <configDir>/spectra).
double peRadiancePerBandRadiance(const std::filesystem::path& configDir, const CameraParams& cam,
                                 const std::string& spectrumSpec);
// The same with an explicit band weight (e.g. a 480-940 nm box, thesis §18.4).
double peRadiancePerBandRadiance(const CameraParams& cam, const Spectrum& shape,
                                 const Spectrum& bandWeight);
// The camera's QE(λ) [pe/photon] and its relative response β(λ).
Spectrum cameraResponse(const CameraParams& cam);
Spectrum spectrumShape(const std::filesystem::path& configDir, const std::string& spec);

}  // namespace nvs::sensor
