#pragma once
// Telemetry → platform state (docs/design.md §5–6). Decoded messages become TelemetryUpdates; the
// PlatformTrack keeps the recent ones and gives the state at any instant:
//
//   position and attitude  linear interpolation between the two samples around t; after the
//                          newest sample, linear extrapolation with the last two samples'
//                          rate for at most max_extrapolation_s (then held); before the
//                          oldest, the oldest. Yaw and roll interpolate along the shorter arc.
//   camera controls, lamps the newest value (a step function).
//   UTC                    the newest telemetry time advanced by (t − its sample time), or the
//                          scenario start + t without any.
//   stale                  t − (newest receive time) > stale_after_s, or nothing received yet.
// Fixed-capacity rings: apply() and sample() allocate nothing.
//
// Boundary check (docs/reliability-inputs.md): apply() refuses an update with any named field
// not finite or outside its range, and counts it (rejected()); the track keeps its last good
// state. The ranges are wide, protocol-independent limits, checked after each parser's own:
//   lat_deg [−90, 90]   lon_deg [−180, 360]   alt_m [−12 000, 1 000 000]
//   roll, pitch, yaw  |angle| ≤ 2π rad        utc_unix_s [0, 2³²]
//   gain_V [0, 10 000]   gate_s [0, 1]   gateMode 0..2   rx_s finite

#include <cstdint>

#include "rt/loop/stages.h"

namespace nvs::rt {

struct TelemetryUpdate {
    enum Field : std::uint32_t {
        kLatLon = 1u << 0,
        kAlt = 1u << 1,
        kRollPitch = 1u << 2,
        kYaw = 1u << 3,
        kUtc = 1u << 4,
        kGain = 1u << 5,
        kGate = 1u << 6,
        kGateMode = 1u << 7,
        kAgc = 1u << 8,
        kLamps = 1u << 9,
    };
    double rx_s = 0.0;  // receive time, run clock
    std::uint32_t fields = 0;
    double lat_deg = 0.0, lon_deg = 0.0, alt_m = 0.0;
    double roll_rad = 0.0, pitch_rad = 0.0, yaw_rad = 0.0;
    double utc_unix_s = 0.0;
    double gain_V = 0.0, gate_s = 0.0;
    std::int32_t gateMode = 0;  // the wire value; accept() checks it is a msg::GateMode
    bool agc = msg::kCommandedAgcDefault;
    std::uint32_t lampMask = 0;  // lamps named in lampBits
    std::uint32_t lampBits = 0;  // which lamp bits this update sets
};

class PlatformTrack {
  public:
    PlatformTrack(const PlatformState& initial, double staleAfter_s, double maxExtrapolation_s)
        : initial_(initial),
          staleAfter_s_(staleAfter_s),
          maxExtrapolation_s_(maxExtrapolation_s),
          controls_(initial) {}
    // False (and counted in rejected()) when the update fails the boundary check.
    bool apply(const TelemetryUpdate& u) noexcept;
    void sample(double t_s, PlatformState& out) const noexcept;
    std::int64_t updates() const { return updates_; }
    std::int64_t rejected() const { return rejected_; }

  private:
    static constexpr int kCap = 64;
    struct Sample {
        double t_s;
        double a, b, c;  // lat, lon, alt  or  yaw, pitch, roll
    };
    struct Ring {
        Sample s[kCap];
        int count = 0;
        int head = 0;  // index of the newest
        void push(const Sample& v) noexcept;
        const Sample& newest(int back) const { return s[(head - back + kCap) % kCap]; }
    };
    // Interpolates/extrapolates ring r at t; `angles` marks a/c as angles (wrap ±π).
    bool at(const Ring& r, double t, bool angles, Sample* out) const noexcept;

    PlatformState initial_;
    double staleAfter_s_;
    double maxExtrapolation_s_;
    PlatformState controls_;  // gain, gate, mode, agc, lamps
    Ring pos_, att_;
    double alt_m_ = 0.0;
    bool haveAlt_ = false;
    double roll_ = 0.0, pitch_ = 0.0;
    bool haveUtc_ = false;
    double utc_unix_s_ = 0.0, utcAt_s_ = 0.0;
    double lastRx_s_ = -1.0;
    std::int64_t updates_ = 0;
    std::int64_t rejected_ = 0;
};

// The boundary check of PlatformTrack::apply: every field the update names is finite and in
// range (the table above).
bool updateInRange(const TelemetryUpdate& u) noexcept;

}  // namespace nvs::rt
