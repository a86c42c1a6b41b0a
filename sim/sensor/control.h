#pragma once
// Step 10, the gain-control policy (docs/sensor.md): who sets the tube gain and the gate of each
// field (the preset, or each field's commanded controls), and the camera's automatic loops that
// measure a field and command a later one (AGC, ABC, auto-gate; BSP is a gain factor of the MCP
// stage). IiccdChain asks GainControl for each field's gain and gate and reports the field back.

#include <cstdint>
#include <memory>

#include "sim/msg/platform.h"
#include "sim/sensor/stages/stage.h"

namespace nvs::sensor {

struct CameraParams;
class GateStage;

enum class AgcMode { Off, Agc, Abc, Bsp, Autogate };

struct ControlParams {
    // --- Controls other tools rely on ------------------------------------------------------
    double gain_V = 6.0;  // [V] tube gain control, 0-8 V with AGC off (thesis §4.3.1)
    AgcMode agc = AgcMode::Off;
    // --- ABC (agc = "abc") -----------------------------------------------------------------
    double abc_screen_limit_A = 5e-9;  // [A] ABC screen-current limit
    double abc_time_constant_s = 0.1;  // [s]
    // --- 10. AGC loop ----------------------------------------------------------------------
    double agc_target_dc = 128.0;
    double agc_time_constant_s = 0.2;
    int agc_lag_fields = 1;
    double agc_min_gain_V = 0.0;
    double agc_max_gain_V = 8.0;

    // Reads its tables of the preset (gain_V, agc, [abc], [agc_loop]) over the defaults above;
    // errors name file:line or the --set KEY.
    void read(const PresetReader& root);
};

// ---- 10. AGC loop ---------------------------------------------------------------------------
class AgcLoop {
  public:
    explicit AgcLoop(const CameraParams& cam);
    double gain_V(std::uint64_t field) const noexcept { return gainRing_[field % kRing]; }
    double gateScale(std::uint64_t field) const noexcept { return gateRing_[field % kRing]; }
    // After field k: measure and command field k + lag.
    void update(const FieldContext& ctx, double level_dc) noexcept;
    void reset() noexcept;
    // Starts the loop from a tube gain (the one in effect when it is switched on).
    void start(double gain_V) noexcept;

  private:
    static constexpr int kRing = 8;
    const CameraParams* cam_;
    double gainRing_[kRing];
    double gateRing_[kRing];
    double gainCmd_V_;
    double gateCmd_;
};

// ---- Controls -------------------------------------------------------------------------------
// The camera's controls as commanded for one field by its operator (telemetry, a scenario's
// platform and timeline): the thesis camera's front-panel switches.
struct CameraCommand {
    double gain_V = 0.0;  // manual tube gain control voltage [V]
    double gate_s = 0.0;  // gate width [s] when gated (0: the preset's gate)
    msg::GateMode gateMode = msg::GateMode::Continuous;
    bool agc = msg::kCommandedAgcDefault;  // the camera's automatic loop switched on
};

// Who sets the controls.
//   Preset   the preset alone: manual gain_V and gate, or its own agc loop (agc, abc, bsp,
//            autogate); commands are ignored.
//   Command  each field's CameraCommand:
//              agc = false   manual: gain_V, clamped to [0, agc_max_gain_V]
//              agc = true    the preset's automatic loop (agc, abc, bsp or autogate); a preset
//                            whose agc is "off" runs the plain AGC loop (the camera's AGC
//                            switch turned on); bsp / autogate keep the tube gain at the
//                            preset's gain_V
//              gate          automatic (the autogate loop's scale on the preset gate) when the
//                            preset's loop is autogate and either agc or gateMode AutoGated;
//                            otherwise by gateMode: Continuous (the photocathode is on for
//                            the whole field), Gated or AutoGated at gate_s, clamped to
//                            [gate_min_s, field] (gate_s = 0 keeps the preset's gate)
enum class ControlSource { Preset, Command };

// The policy above for one chain: each field's gain and gate, and the loop that measures it.
class GainControl {
  public:
    // `cam` must outlive this (the chain's own copy of the preset).
    GainControl(const CameraParams& cam, ControlSource source);
    ~GainControl();
    GainControl(const GainControl&) = delete;
    GainControl& operator=(const GainControl&) = delete;

    // This field's gain, gate and the loop that measures it (null: none).
    struct Controls {
        double gain_V = 0.0;
        double gate_s = 0.0;
        AgcLoop* loop = nullptr;
    };
    Controls forField(const CameraCommand& cmd, std::uint64_t field, double period_s,
                      const GateStage& gate) noexcept;

  private:
    const CameraParams* cam_;
    // cam_ with its automatic loop switched on (ControlSource::Command).
    std::unique_ptr<const CameraParams> camAuto_;
    ControlSource source_;
    // Command: the gain applied to the last field, and whether agcAuto_ ran for it (a loop
    // switched on starts from the gain in effect, not from the preset's).
    double lastGain_V_ = 0.0;
    bool autoRunning_ = false;
    AgcLoop agc_;      // the preset's own loop
    AgcLoop agcAuto_;  // the loop a command's agc switch turns on
};

}  // namespace nvs::sensor
