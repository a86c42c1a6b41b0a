#include "sim/sensor/control.h"

#include <algorithm>
#include <cmath>

#include "sim/core/units.h"
#include "sim/sensor/camera.h"
#include "sim/sensor/preset_reader.h"
#include "sim/sensor/stages/gate.h"

namespace nvs::sensor {

void ControlParams::read(const PresetReader& root) {
    gain_V = root.get<double>("gain_V", gain_V);
    require(gain_V >= 0.0 && gain_V <= 9.0, root, "gain_V", "must be in 0..9 V");
    const std::string mode = root.get<std::string>("agc", "off");
    if (mode == "off")
        agc = AgcMode::Off;
    else if (mode == "agc")
        agc = AgcMode::Agc;
    else if (mode == "abc")
        agc = AgcMode::Abc;
    else if (mode == "bsp")
        agc = AgcMode::Bsp;
    else if (mode == "autogate")
        agc = AgcMode::Autogate;
    else
        root.fail("agc", "must be off, agc, abc, bsp or autogate, not '" + mode + "'");

    const PresetReader abc = root.sub("abc");
    abc_screen_limit_A = positive(abc, "screen_limit_A", abc_screen_limit_A);
    abc_time_constant_s = positive(abc, "time_constant_s", abc_time_constant_s);

    const PresetReader loop = root.sub("agc_loop");
    agc_target_dc = positive(loop, "target_dc", agc_target_dc);
    agc_time_constant_s = positive(loop, "time_constant_s", agc_time_constant_s);
    agc_lag_fields = loop.get<int>("lag_fields", agc_lag_fields);
    require(agc_lag_fields >= 0 && agc_lag_fields <= 7, loop, "lag_fields", "must be in 0..7");
    agc_min_gain_V = nonNegative(loop, "min_gain_V", agc_min_gain_V);
    agc_max_gain_V = positive(loop, "max_gain_V", agc_max_gain_V);
    require(agc_min_gain_V < agc_max_gain_V, loop, "max_gain_V", "must exceed min_gain_V");
}

// ---- 10. AGC loop ---------------------------------------------------------------------------

AgcLoop::AgcLoop(const CameraParams& c) : cam_(&c) {
    reset();
}

void AgcLoop::reset() noexcept {
    start(cam_->gain_V);
}

void AgcLoop::start(double gain_V) noexcept {
    for (int i = 0; i < kRing; ++i) {
        gainRing_[i] = gain_V;
        gateRing_[i] = 1.0;
    }
    gainCmd_V_ = gain_V;
    gateCmd_ = 1.0;
}

void AgcLoop::update(const FieldContext& ctx, double level_dc) noexcept {
    const CameraParams& c = *cam_;
    if (c.agc == AgcMode::Off || c.agc == AgcMode::Bsp) return;
    const double signal = std::max(level_dc - c.video_offset_dc, 0.25);
    const double want = std::max(c.agc_target_dc - c.video_offset_dc, 0.25);
    int lag = std::max(c.agc_lag_fields, 1);
    if (c.agc == AgcMode::Agc) {
        // Video AGC: the gain that would bring this field's level to the target, approached
        // with a first-order lag of time constant τ, applied `lag` fields later.
        const double gNow = c.mcpGain(ctx.gain_V);
        const double vTarget = std::clamp(c.controlVoltageForGain(gNow * want / signal),
                                          c.agc_min_gain_V, c.agc_max_gain_V);
        const double a = 1.0 - std::exp(-ctx.period_s / c.agc_time_constant_s);
        gainCmd_V_ += a * (vTarget - gainCmd_V_);
    } else if (c.agc == AgcMode::Abc) {
        // ABC: the screen current is sensed directly (no video lag beyond the field in
        // which it is measured); above the limit the gain is cut in proportion, below it
        // recovers toward the manual setting, both with the ABC time constant.
        const double screen_A = ctx.mcpOut_e * kElectronCharge_C / ctx.period_s;
        double vTarget = c.gain_V;
        if (screen_A > c.abc_screen_limit_A) {
            const double gNow = c.mcpGain(ctx.gain_V);
            vTarget =
                std::min(c.gain_V, c.controlVoltageForGain(gNow * c.abc_screen_limit_A / screen_A));
        }
        vTarget = std::clamp(vTarget, c.agc_min_gain_V, c.agc_max_gain_V);
        const double a = 1.0 - std::exp(-ctx.period_s / c.abc_time_constant_s);
        gainCmd_V_ += a * (vTarget - gainCmd_V_);
        lag = 1;
    } else if (c.agc == AgcMode::Autogate) {
        // Auto-gating: the gain stays at the manual setting and the gate duty cycle carries
        // the loop (log-domain first-order lag), between the shortest gate and the field.
        const double minScale = std::min(c.gate_min_s / ctx.period_s, 1.0);
        const double target = std::clamp(gateCmd_ * want / signal, minScale, 1.0);
        const double a = 1.0 - std::exp(-ctx.period_s / c.agc_time_constant_s);
        gateCmd_ = std::exp(std::log(gateCmd_) + a * (std::log(target) - std::log(gateCmd_)));
    }
    const std::uint64_t k = ctx.field + static_cast<std::uint64_t>(lag);
    // Fields between now and k keep what was already commanded for them.
    gainRing_[k % kRing] = gainCmd_V_;
    gateRing_[k % kRing] = gateCmd_;
}

// ---- The policy -----------------------------------------------------------------------------

namespace {

// The preset with its automatic loop switched on: what the camera's AGC switch selects.
CameraParams withAutomaticLoop(const CameraParams& cam) {
    CameraParams c = cam;
    if (c.agc == AgcMode::Off) c.agc = AgcMode::Agc;
    return c;
}

}  // namespace

GainControl::GainControl(const CameraParams& cam, ControlSource source)
    : cam_(&cam),
      camAuto_(std::make_unique<const CameraParams>(withAutomaticLoop(cam))),
      source_(source),
      agc_(cam),
      agcAuto_(*camAuto_) {}

GainControl::~GainControl() = default;

GainControl::Controls GainControl::forField(const CameraCommand& cmd, std::uint64_t field,
                                            double period_s, const GateStage& gate) noexcept {
    const CameraParams& cam = *cam_;
    const CameraParams& autoCam = *camAuto_;
    Controls c;
    bool autogate = false;
    if (source_ == ControlSource::Preset) {
        // The preset alone: manual gain for off / bsp / autogate, else its loop's command.
        const AgcMode m = cam.agc;
        c.gain_V = m == AgcMode::Off || m == AgcMode::Bsp || m == AgcMode::Autogate
                       ? cam.gain_V
                       : agc_.gain_V(field);
        autogate = m == AgcMode::Autogate;
        c.loop = &agc_;
    } else {
        const AgcMode m = autoCam.agc;
        const bool gainLoop = cmd.agc && (m == AgcMode::Agc || m == AgcMode::Abc);
        autogate = m == AgcMode::Autogate && (cmd.agc || cmd.gateMode == msg::GateMode::AutoGated);
        if (gainLoop) {
            // Switched on now (or at the first field): the loop starts from the gain in
            // effect — the last field's, or at the first field the commanded one.
            if (!autoRunning_) {
                agcAuto_.start(field == 0 ? std::clamp(cmd.gain_V, autoCam.agc_min_gain_V,
                                                       autoCam.agc_max_gain_V)
                                          : lastGain_V_);
            }
            c.gain_V = agcAuto_.gain_V(field);
        } else if (cmd.agc) {
            c.gain_V = cam.gain_V;  // bsp / autogate: the tube gain stays at the preset's
        } else {
            c.gain_V = std::clamp(cmd.gain_V, 0.0, cam.agc_max_gain_V);
        }
        if (gainLoop || autogate) c.loop = &agcAuto_;
        autoRunning_ = gainLoop;
        lastGain_V_ = c.gain_V;
    }
    // 2. gate
    if (autogate) {
        c.gate_s = gate.gate_s(period_s, c.loop->gateScale(field));
    } else if (source_ == ControlSource::Preset || cmd.gateMode != msg::GateMode::Continuous) {
        c.gate_s = source_ == ControlSource::Command && cmd.gate_s > 0.0
                       ? std::clamp(cmd.gate_s, cam.gate_min_s, period_s)
                       : gate.gate_s(period_s, 1.0);
    } else {
        c.gate_s = period_s;  // continuous
    }
    return c;
}

}  // namespace nvs::sensor
