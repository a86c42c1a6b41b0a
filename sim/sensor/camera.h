#pragma once
// Camera preset: every parameter of the IICCD chain (docs/design.md §4.5), read from
// config/cameras/NAME.toml with strict keys (unknown keys are errors naming file:line:col) and
// `--set KEY=VALUE` overrides (an override naming no parameter is an error naming the argument).
//
// Defaults live here, in code. Each field states its unit in its name or comment and the source
// of its default; a preset file repeats the parameters it relies on with their sources.

#include <cstdint>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include "sim/core/spectrum.h"

namespace nvs::sensor {

enum class AgcMode { Off, Agc, Abc, Bsp, Autogate };
enum class BloomDirection { Off, Vertical, Horizontal };
enum class SolidAngleModel { Lens, CcdArea };
enum class ScanMode { Frame, Field };

struct CameraParams {
    std::string name;
    FileLoc loc;  // where the preset came from

    // --- Format and timing -------------------------------------------------------------------
    int width = 768;               // [px] Appendix A Table 11-2: 768 (H)
    int height = 494;              // [px] 493 active lines (Table 11-2), even for two fields
    double field_rate_Hz = 59.94;  // [Hz] 525 lines 60 Hz 2:1 interlace (Table 11-2)
    ScanMode scan = ScanMode::Field;
    // Field scan: which field comes first in time. Top: field 0 (and every even field) holds
    // rows 0, 2, 4, …; bottom: rows 1, 3, 5, … (y4m "It" / "Ib", V4L2_FIELD_INTERLACED_TB/BT).
    bool topFieldFirst = true;

    // --- Controls other tools rely on -----------------------------------------------------
    double gain_V = 6.0;  // [V] tube gain control, 0-8 V with AGC off (thesis §4.3.1)
    AgcMode agc = AgcMode::Off;
    double f_number = 5.6;  // thesis §4.3: collection at f/5.6, wide open

    // --- 1. Optics -----------------------------------------------------------------------
    double focal_length_mm = 36.0;  // thesis §4.3 (Sony 16-64 zoom at ~36 mm)
    double optics_transmission = 0.9;
    bool cos4 = true;
    double optics_fill_factor = 1.0;  // fraction of the pixel footprint that collects
    SolidAngleModel solid_angle = SolidAngleModel::Lens;

    // --- Spectral conversion (W/m2/sr inputs only) -----------------------------------------
    std::filesystem::path response_file;  // relative response beta(λ), peak 1
    std::string response_column = "response_rel";
    double qe_peak = 0.25;          // [pe/photon] GaAs "typically 25 %" (thesis §6.2.4)
    double monochromatic_nm = 0.0;  // > 0: thesis eq. 6.25 single-wavelength conversion

    // --- 2. Gate -------------------------------------------------------------------------
    double gate_s = 0.0;         // [s] 0 = the whole field
    double gate_min_s = 100e-9;  // [s] fastest gate, 100 ns (Appendix A sec4.3)

    // --- 3. Photocathode -----------------------------------------------------------------
    bool shot_noise = true;
    double ebi_lm_cm2 = 3.5e-11;  // [lm/cm2] equivalent background illumination (Table 11-1)
    double cathode_sensitivity_uA_lm = 1800.0;  // [µA/lm] Gen III GaAs, typical
    double taper_magnification = 1.636;         // cathode/CCD size: 18 mm -> 11 mm (2/3")

    // --- 4. Bright-source protection (agc = "bsp") -------------------------------------------
    double bsp_knee_A = 2e-11;  // [A] cathode current at which gain halves
    double bsp_exponent = 1.0;

    // --- 5. MCP ---------------------------------------------------------------------------
    // Absolute gain: Vc directly, or (anchor) the tube's luminous gain at a control voltage,
    // from which Vc follows (luminousGain_fL_fc).
    double mcp_crossover_V = 520.0;        // [V] Vc, eq. 6.1 (typical 350-530 V)
    double luminous_gain_fL_fc = 0.0;      // [fL/fc] anchor; 0: crossover_V as given
    double luminous_gain_control_V = 0.0;  // [V] control voltage of that figure
    double mcp_exponent = 10.0;            // g, eq. 6.1 (typical 8.5-13)
    double mcp_offset_V = 40.0;            // [V] Vm = offset + slope·gain_V
    double mcp_V_per_control_V = 190.0;
    double mcp_noise_factor = 1.6;  // F, excess noise factor
    bool mcp_noise = true;
    bool mcp_enabled = true;
    double abc_screen_limit_A = 5e-9;  // [A] ABC screen-current limit
    double abc_time_constant_s = 0.1;  // [s]

    // --- 3b. Halo: photoelectrons backscattered at the MCP input land on a disk ------------
    bool halo_enabled = false;
    double halo_fraction = 0.0;   // share of the photoelectrons that land displaced
    double halo_gap_um = 150.0;   // cathode–MCP gap d; elastic backscatter lands within 2d
    double halo_radius_um = 0.0;  // ring radius at the cathode; 0: 2·gap
    double haloRadius_um() const {
        return halo_radius_um > 0.0 ? halo_radius_um : 2.0 * halo_gap_um;
    }

    // --- 5b. MCP local saturation: the charge a channel can give, recharged through its wall -
    bool mcpsat_enabled = false;
    double mcpsat_pixel_charge_e = 2.4e4;  // output electrons available per CCD-pixel area
    double mcpsat_recharge_s = 0.01;       // recharge time constant τ

    // --- 6. Phosphor ----------------------------------------------------------------------
    bool phosphor_enabled = true;
    std::string phosphor_type = "P20";
    std::vector<double> phosphor_decay_s = {1e-4, 2e-3, 0.05};
    std::vector<double> phosphor_weight = {0.9, 0.09, 0.01};
    double screen_voltage_V = 6000.0;        // Va, thesis §6.2
    double screen_dead_voltage_V = 1500.0;   // Vd, eq. 6.2
    double phosphor_photons_per_eV = 0.065;  // P, eq. 6.2
    double phosphor_peak_nm = 545.0;         // emission peak (P20)
    double phosphor_efficacy_lm_W = 500.0;   // luminous efficacy of the screen's emission
    double taper_transmission = 0.3;         // T_fot, eq. 6.2
    double ccd_window_transmission = 1.0;    // T_CCD, eq. 6.2
    double ccd_qe = 0.35;                    // QE_CCD at the P20 peak, eq. 6.2
    double ccd_fill_factor = 1.0;            // light-collecting fraction of a CCD cell

    // --- 7. MTF (frequencies in the image plane = photocathode plane) ----------------------
    bool mtf_enabled = true;
    double ii_fc_cyc_mm = 13.75;  // ξc of exp(-(ξ/ξc)^n), eq. 6.14
    double ii_index = 1.18;       // n
    double fibre_pitch_um = 6.0;  // thesis §7.4.1 (0 = no fibre MTF)
    bool ccd_aperture_mtf = true;
    double digitiser_fc_cyc_mm = 0.0;  // 0 = no digitiser stage
    double digitiser_index = 1.0;

    // --- 8. CCD ---------------------------------------------------------------------------
    double pitch_x_um = 11.0;  // Table 11-2, cell 11 x 13 µm
    double pitch_y_um = 13.0;
    double full_well_e = 60000.0;  // [e] 0 = unlimited
    BloomDirection bloom = BloomDirection::Vertical;
    double smear_rel = 0.0;     // fraction of a column's mean charge added during transfer
    double dark_e_s = 0.0;      // [e/s] CCD dark current
    double read_noise_e = 0.0;  // [e rms]
    double prnu_rel = 0.0;      // fixed-pattern gain non-uniformity, rms fraction

    // --- 9. Video -------------------------------------------------------------------------
    double video_gain_dc_per_e = 0.004;  // [DC/e]
    double video_offset_dc = 26.0;       // [DC]
    double video_noise_dc = 0.0;         // [DC rms] additive pre-amplifier noise
    double gamma = 1.0;                  // Table 11-2: gamma 1.0
    int adc_bits = 8;

    // --- 10. AGC loop ---------------------------------------------------------------------
    double agc_target_dc = 128.0;
    double agc_time_constant_s = 0.2;
    int agc_lag_fields = 1;
    double agc_min_gain_V = 0.0;
    double agc_max_gain_V = 8.0;

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
    // MCP gain at a control voltage, eq. 6.1: G = (Vm/Vc)^g, Vm = offset + slope·gain_V.
    double mcpGain(double gainControl_V) const;
    // Inverse of mcpGain (for the AGC loop).
    double controlVoltageForGain(double gain) const;
    // CCD electrons per MCP output electron, eq. 6.2/6.3.
    double ccdElectronsPerMcpElectron() const;
    // Luminous flux out of the screen per watt of electron beam reaching it [lm/W]:
    // P·(hc/λ_peak)/e photons' energy per eV of beam, times the emission's efficacy.
    double screenLumensPerBeamWatt() const;
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
