#include "sim/bolometer/stages/shutter.h"

#include <cmath>

#include "sim/bolometer/camera.h"
#include "sim/core/simd.h"

namespace nvs::bolometer {

void ShutterParams::read(const Reader& root) {
    const Reader s = root.sub("shutter");
    shutter_enabled = s.get<bool>("enabled", shutter_enabled);
    ffc_interval_s = positive(s, "interval_s", ffc_interval_s);
    ffc_delta_K = positive(s, "delta_K", ffc_delta_K);
    ffc_closed_frames = s.get<int>("closed_frames", ffc_closed_frames);
    require(ffc_closed_frames >= 1 && ffc_closed_frames <= 1000, s, "closed_frames",
            "must be in 1 … 1000");
    ffc_settle_frames = s.get<int>("settle_frames", ffc_settle_frames);
    require(ffc_settle_frames >= 0 && ffc_settle_frames < ffc_closed_frames, s, "settle_frames",
            "must be in 0 … closed_frames − 1");
}

ShutterStage::ShutterStage(const ThermalCameraParams& cam)
    : enabled_(cam.shutter_enabled),
      interval_s_(cam.ffc_interval_s),
      delta_K_(cam.ffc_delta_K),
      closedFrames_(cam.ffc_closed_frames),
      settle_(cam.ffc_settle_frames),
      sum_(cam.width, cam.height),
      correction_(cam.width, cam.height) {}

bool ShutterStage::closedFor(double t_s, double fpa_K) noexcept {
    if (!enabled_) return false;
    if (closedLeft_ == 0) {
        const bool due = count_ == 0 || t_s - lastT_s_ >= interval_s_ ||
                         std::abs(fpa_K - lastFpa_K_) >= delta_K_;
        if (!due) return false;
        closedLeft_ = closedFrames_;
        closedSeen_ = 0;
        pendingT_s_ = t_s;
        pendingFpa_K_ = fpa_K;
        sum_.fill(0.0f);
    }
    return true;
}

bool ShutterStage::holdAfterOpen() noexcept {
    if (holdLeft_ == 0) return false;
    --holdLeft_;
    return true;
}

void ShutterStage::accumulateRow(int y, const float* v) noexcept {
    if (closedSeen_ < settle_) return;
    float* s = sum_.row(y);
    for (int x = 0; x < sum_.width(); ++x)
        s[x] += v[x];
}

void ShutterStage::endClosedFrame() noexcept {
    ++closedSeen_;
    if (--closedLeft_ == 0) finish();
}

void ShutterStage::accumulate(ImageView<const float> volts) noexcept {
    for (int y = 0; y < sum_.height(); ++y)
        accumulateRow(y, volts.row(y));
    endClosedFrame();
}

void ShutterStage::finish() noexcept {
    // c_i = V̄_i − mean V̄ (double sums, row by row).
    const float inv = 1.0f / static_cast<float>(closedFrames_ - settle_);
    double total = 0.0;
    for (int y = 0; y < sum_.height(); ++y) {
        double row = 0.0;
        const float* s = sum_.row(y);
        for (int x = 0; x < sum_.width(); ++x)
            row += static_cast<double>(s[x] * inv);
        total += row;
    }
    const float mean =
        static_cast<float>(total / (static_cast<double>(sum_.width()) * sum_.height()));
    for (int y = 0; y < sum_.height(); ++y) {
        const float* s = sum_.row(y);
        float* c = correction_.row(y);
        for (int x = 0; x < sum_.width(); ++x)
            c[x] = s[x] * inv - mean;
    }
    ++count_;
    holdLeft_ = settle_;
    lastT_s_ = pendingT_s_;
    lastFpa_K_ = pendingFpa_K_;
}

NVS_SIMD_CLONES void ShutterStage::correctRow(int y, float* v) const noexcept {
    const float* c = correction_.row(y);
    for (int x = 0; x < correction_.width(); ++x)
        v[x] -= c[x];
}

void ShutterStage::correct(ImageView<float> volts) const noexcept {
    for (int y = 0; y < volts.height(); ++y)
        correctRow(y, volts.row(y));
}

}  // namespace nvs::bolometer
