#pragma once
// Step 5, shutter flat-field correction, FFC (docs/bolometer.md).
//
//   name            unit  default  meaning / source
//   enabled         bool  true     a shutter is fitted (shutterless cores: false)
//   interval_s      s     180      FFC at least this often (typical default, preset)
//   delta_K         K     1.5      ... or when the focal plane moved this much since the last
//   closed_frames   1     8        frames the shutter stays closed (output frozen, flagged)
//   settle_frames   1     2        first closed frames not averaged, and first open frames
//                                  still frozen (the pixels' lag settles either way)
//
// An FFC starts at the first frame (the core's start-up FFC), then whenever interval_s has
// passed or |T_fpa − T_fpa,FFC| ≥ delta_K. While the shutter is closed the array sees a uniform
// blackbody at the focal-plane temperature; the outputs stay frozen at the last good frame
// and the frame info says so, and stay so for settle_frames more after the shutter opens, while
// the pixels' lag moves from the shutter to the scene (no flash of the shutter's level). The closed
// frames after the settling ones are averaged, V̄_i, and the offset map becomes c_i = V̄_i − mean_j
// V̄_j: the corrected output V_i − c_i is flat on the shutter and keeps its mean level. What remains
// afterwards is the noise of the average (σ/√n), the gain non-uniformity times the scene's
// difference from the shutter, and the offsets' drift with T_fpa since the FFC, which grows again
// until the next one.

#include <cstdint>
#include <vector>

#include "sim/bolometer/stages/stage.h"
#include "sim/core/image.h"

namespace nvs::bolometer {

struct ShutterParams {
    bool shutter_enabled = true;
    double ffc_interval_s = 180.0;
    double ffc_delta_K = 1.5;
    int ffc_closed_frames = 8;
    int ffc_settle_frames = 2;

    void read(const Reader& root);
};

class ShutterStage {
  public:
    explicit ShutterStage(const ThermalCameraParams& cam);
    // Whether the shutter is in front of the array for the frame at t_s (starts an FFC when
    // one is due).
    bool closedFor(double t_s, double fpa_K) noexcept;
    // For an open frame: whether the output is still held after the shutter opened (counts
    // the held frames down).
    bool holdAfterOpen() noexcept;
    // While closed: takes this frame's volts (averaged after the settling frames); the last
    // closed frame computes the new offset map.
    void accumulate(ImageView<const float> volts) noexcept;
    // V_i − c_i, in place.
    void correct(ImageView<float> volts) const noexcept;
    // accumulate() and correct() in rows: accumulateRow for every row, then endClosedFrame();
    // correctRow for a row.
    void accumulateRow(int y, const float* volts) noexcept;
    void endClosedFrame() noexcept;
    void correctRow(int y, float* volts) const noexcept;
    std::uint64_t ffcCount() const { return count_; }
    double lastFfc_s() const { return lastT_s_; }
    double lastFfcFpa_K() const { return lastFpa_K_; }

  private:
    void finish() noexcept;
    bool enabled_;
    double interval_s_, delta_K_;
    int closedFrames_, settle_;
    int closedLeft_ = 0;  // closed frames still to come in this FFC
    int closedSeen_ = 0;  // closed frames taken so far
    int holdLeft_ = 0;    // open frames still to hold after this FFC
    std::uint64_t count_ = 0;
    double lastT_s_ = 0.0, lastFpa_K_ = 0.0;
    double pendingT_s_ = 0.0, pendingFpa_K_ = 0.0;
    ImageF sum_;         // Σ of the averaged closed frames [V]
    ImageF correction_;  // c_i [V]
};

}  // namespace nvs::bolometer
