#include "sim/bolometer/chain.h"

namespace nvs::bolometer {

BolometerChain::BolometerChain(const ThermalCameraParams& cam, std::uint64_t seed,
                               const std::filesystem::path& configDir, FftPlanning planning)
    : cam_(cam),
      optics_(cam, configDir, planning),
      detector_(cam),
      focal_(cam, seed),
      noise_(cam, seed),
      shutter_(cam),
      adc_(cam),
      agc_(cam),
      power_W_(cam.width, cam.height),
      row_(std::make_unique<float[]>(static_cast<std::size_t>(cam.width))),
      raw_(cam.width, cam.height),
      display_(cam.width, cam.height) {}

const FrameInfo& BolometerChain::process(ImageView<const float> radiance) noexcept {
    FrameInfo info;
    info.frame = frame_;
    info.t_s = static_cast<double>(frame_) * cam_.framePeriod_s();
    if (radiance.width() != cam_.width || radiance.height() != cam_.height) {
        info.size_mismatch = true;
        info_ = info;
        return info_;
    }
    // 3 (its temperature first: the shutter's decision and the offsets' drift need it).
    info.fpa_K = cam_.fpaTemperature_K(info.t_s);
    const bool closed = shutter_.closedFor(info.t_s, info.fpa_K);
    const bool hold = !closed && shutter_.holdAfterOpen();
    info.shutter_closed = closed;
    info.ffc_started = closed && !info_.shutter_closed;
    // 1 Optics: the scene through the lens, or the shutter (a blackbody at T_fpa) before it.
    if (closed) {
        optics_.uniform(cam_.bandRadiance_W_m2_sr(info.fpa_K), power_W_.view());
    } else {
        info.bad_input_px = optics_.apply(radiance, power_W_.view());
    }
    // 2 Detector, 3 focal plane, 4 noise, 5 shutter (a closed frame feeds the offset estimate;
    // the output stays frozen while closed and settle_frames after), 6 ADC: row by row through one
    // scratch row, the same arithmetic as the stages' whole-image apply().
    const float keep = detector_.beginFrame();
    const float dT = static_cast<float>(info.fpa_K - cam_.ambient_K);
    noise_.beginFrame(frame_);
    float* v = row_.get();
    std::uint64_t sum = 0;
    for (int y = 0; y < cam_.height; ++y) {
        detector_.applyRow(y, power_W_.row(y), v, keep);
        focal_.applyRow(y, v, dT);
        noise_.applyRow(y, v);
        if (closed) {
            shutter_.accumulateRow(y, v);
        } else if (!hold) {
            shutter_.correctRow(y, v);
            std::uint32_t rowSum = 0;
            info.clipped_px += adc_.applyRow(v, raw_.row(y), cam_.width, rowSum);
            sum += rowSum;
        }
    }
    if (closed) shutter_.endClosedFrame();
    if (closed || hold) {
        info.frozen = true;
    } else {
        sumRaw_ = static_cast<double>(sum);
        agc_.apply(raw_.cview(), display_.view());  // 7 AGC
    }
    info.ffc_count = shutter_.ffcCount();
    info.since_ffc_s = info.t_s - shutter_.lastFfc_s();
    info.mean_raw = sumRaw_ / (static_cast<double>(cam_.width) * cam_.height);
    ++frame_;
    info_ = info;
    return info_;
}

}  // namespace nvs::bolometer
