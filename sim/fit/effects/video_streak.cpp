// video_streak: the line's droop through an AC-coupled video path. Between the camera's output
// and the grabber's ADC the video passes a coupling capacitor, and the level is clamped to
// black at each line's back porch; within a line the coupling is a high-pass, so the signal
// sags by part of its own running mean: out = S − f·m, m a first-order low-pass of S along the
// line with time constant τ, started at 0 at the line's start. A bright source leaves a dark
// streak to its right that recovers over τ; a flat line droops from left to right. Where the
// coupling is long against the line (τ of milliseconds against its 52.6 µs) nothing shows; a
// short coupling, or a clamp that holds poorly, gives the streaks that trackers meet behind
// lamps. Chain stage: the video stage's droop, `[video] streak_fraction` and `streak_tau_px`
// (sim/sensor/stages/video.cpp, VideoStage::droopRow; docs/sensor.md stage 9).
//
// Nothing in the model trails to one side only: every other spread of the chain and of the
// catalog is symmetric, and the droop's smooth loss across the frame is a gain that grows
// with x, not a shape of the baseline's gain.

#include <vector>

#include "sim/fit/effect_registry.h"
#include "sim/fit/text.h"
#include "sim/sensor/stages/video.h"

namespace nvs::fit {

namespace {

// Each row of each frame through the droop of the chain's video stage (the same recursion,
// on the signal in DC above offset: the droop is linear, so it acts alike on electrons).
void apply(const Work& w, const std::vector<double>& p, std::vector<Plane>& S) {
    for (Plane& P : S)
        for (int y = 0; y < w.h; ++y) {
            float* r = P.data() + static_cast<std::size_t>(y) * w.w;
            sensor::VideoStage::droopRow(r, r, w.w, p[0], p[1]);
        }
}

bool present(const sensor::CameraParams& cam) {
    return cam.streak_fraction > 0.0;
}

std::string cause(const std::vector<double>& p) {
    return textf(
        "the video line droops after what it carried: %.3g of the line's running mean (time "
        "constant %.3g px) is taken off, a dark streak to the right of bright objects, as an "
        "AC-coupled video path makes; the model's video path is DC-coupled",
        p[0], p[1]);
}

}  // namespace

const RegisteredEffect& videoStreak() {
    static const RegisteredEffect e{
        "video_streak",
        "video (stage 9), the AC-coupled line's droop: [video] streak_fraction, streak_tau_px",
        {{"fraction", "video.streak_fraction", "1", 0.003, 0.9, 0.05, 0.2},
         {"tau_px", "video.streak_tau_px", "px", 1.0, 3000.0, 10.0, 100.0}},
        present,
        apply,
        cause};
    return e;
}

}  // namespace nvs::fit
