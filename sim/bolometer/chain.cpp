#include "sim/bolometer/chain.h"

namespace nvs::bolometer {

BolometerChain::BolometerChain(const ThermalCameraParams& cam, std::uint64_t seed)
    : cam_(cam),
      optics_(cam),
      detector_(cam),
      focal_(cam, seed),
      noise_(cam, seed),
      shutter_(cam),
      adc_(cam),
      agc_(cam),
      power_W_(cam.width, cam.height),
      volts_(cam.width, cam.height),
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
    info.ffc_started = closed && !info_.frozen;
    // 1 Optics: the scene through the lens, or the shutter (a blackbody at T_fpa) before it.
    if (closed) {
        optics_.uniform(cam_.bandRadiance_W_m2_sr(info.fpa_K), power_W_.view());
    } else {
        info.bad_input_px = optics_.apply(radiance, power_W_.view());
    }
    // 2 Detector, 3 focal plane, 4 noise.
    detector_.apply(power_W_.cview(), volts_.view());
    focal_.apply(volts_.view(), info.fpa_K);
    noise_.apply(volts_.view(), frame_);
    // 5 Shutter: a closed frame feeds the offset estimate and the output stays frozen.
    if (closed) {
        shutter_.accumulate(volts_.cview());
        info.frozen = true;
    } else {
        shutter_.correct(volts_.view());
        // 6 ADC, 7 AGC.
        info.clipped_px = adc_.apply(volts_.cview(), raw_.view(), sumRaw_);
        agc_.apply(raw_.cview(), display_.view());
    }
    info.ffc_count = shutter_.ffcCount();
    info.since_ffc_s = info.t_s - shutter_.lastFfc_s();
    info.mean_raw = sumRaw_ / (static_cast<double>(cam_.width) * cam_.height);
    ++frame_;
    info_ = info;
    return info_;
}

}  // namespace nvs::bolometer
