#include "rt/telemetry/track.h"

#include <algorithm>
#include <cmath>

#include "sim/core/units.h"

namespace nvs::rt {

namespace {

constexpr double kMinAlt_m = -12000.0;
constexpr double kMaxAlt_m = 1.0e6;

double wrapPi(double a) {
    a = std::fmod(a + kPi, kTwoPi);
    if (a < 0) a += kTwoPi;
    return a - kPi;
}

}  // namespace

void PlatformTrack::Ring::push(const Sample& v) noexcept {
    if (count > 0 && v.t_s < newest(0).t_s) return;  // out of order: keep the track monotonic
    if (count > 0 && v.t_s == newest(0).t_s) {
        s[head] = v;
        return;
    }
    head = (head + 1) % kCap;
    s[head] = v;
    if (count < kCap) ++count;
}

bool PlatformTrack::at(const Ring& r, double t, bool angles, Sample* out) const noexcept {
    if (r.count == 0) return false;
    const auto lerp = [angles](const Sample& p, const Sample& q, double f) {
        Sample o{};
        o.t_s = p.t_s + f * (q.t_s - p.t_s);
        o.a = angles ? wrapPi(p.a + f * wrapPi(q.a - p.a)) : p.a + f * (q.a - p.a);
        o.b = p.b + f * (q.b - p.b);
        o.c = angles ? wrapPi(p.c + f * wrapPi(q.c - p.c)) : p.c + f * (q.c - p.c);
        return o;
    };
    const Sample& n0 = r.newest(0);
    if (t >= n0.t_s) {
        if (r.count < 2) {
            *out = n0;
            return true;
        }
        // Extrapolate along the last two samples' rate, for at most max_extrapolation_s.
        const Sample& n1 = r.newest(1);
        const double span = n0.t_s - n1.t_s;
        const double ahead = std::fmin(t - n0.t_s, maxExtrapolation_s_);
        *out = span > 0.0 ? lerp(n1, n0, 1.0 + ahead / span) : n0;
        return true;
    }
    for (int back = 1; back < r.count; ++back) {
        const Sample& p = r.newest(back);
        if (p.t_s <= t) {
            const Sample& q = r.newest(back - 1);
            *out = lerp(p, q, (t - p.t_s) / (q.t_s - p.t_s));
            return true;
        }
    }
    *out = r.newest(r.count - 1);  // before the oldest kept: hold it
    return true;
}

bool updateInRange(const TelemetryUpdate& u) noexcept {
    // `!(lo <= v && v <= hi)` is also true for NaN.
    const auto in = [](double v, double lo, double hi) { return lo <= v && v <= hi; };
    constexpr double kMaxAngle_rad = 2.0 * kPi + 1e-9;
    const std::uint32_t f = u.fields;
    if (!std::isfinite(u.rx_s)) return false;
    if ((f & TelemetryUpdate::kLatLon) &&
        !(in(u.lat_deg, -90.0, 90.0) && in(u.lon_deg, -180.0, 360.0))) {
        return false;
    }
    if ((f & TelemetryUpdate::kAlt) && !in(u.alt_m, kMinAlt_m, kMaxAlt_m)) return false;
    if ((f & TelemetryUpdate::kRollPitch) && !(in(u.roll_rad, -kMaxAngle_rad, kMaxAngle_rad) &&
                                               in(u.pitch_rad, -kMaxAngle_rad, kMaxAngle_rad))) {
        return false;
    }
    if ((f & TelemetryUpdate::kYaw) && !in(u.yaw_rad, -kMaxAngle_rad, kMaxAngle_rad)) return false;
    if ((f & TelemetryUpdate::kUtc) && !in(u.utc_unix_s, 0.0, 4294967296.0)) return false;
    if ((f & TelemetryUpdate::kGain) && !in(u.gain_V, 0.0, 10000.0)) return false;
    if ((f & TelemetryUpdate::kGate) && !in(u.gate_s, 0.0, 1.0)) return false;
    msg::GateMode mode = msg::GateMode::Continuous;
    if ((f & TelemetryUpdate::kGateMode) && !msg::gateModeFromValue(u.gateMode, &mode))
        return false;
    return true;
}

bool PlatformTrack::apply(const TelemetryUpdate& u) noexcept {
    if (!updateInRange(u)) {
        ++rejected_;  // the last good state is kept
        return false;
    }
    ++updates_;
    if (u.rx_s > lastRx_s_) lastRx_s_ = u.rx_s;
    if (u.fields & TelemetryUpdate::kAlt) {
        alt_m_ = u.alt_m;
        haveAlt_ = true;
    }
    if (u.fields & TelemetryUpdate::kLatLon) {
        pos_.push({u.rx_s, u.lat_deg, u.lon_deg, haveAlt_ ? alt_m_ : initial_.alt_m});
    } else if ((u.fields & TelemetryUpdate::kAlt) && pos_.count > 0) {
        const Sample& n = pos_.newest(0);
        pos_.push({u.rx_s, n.a, n.b, u.alt_m});
    }
    if (u.fields & TelemetryUpdate::kRollPitch) {
        roll_ = u.roll_rad;
        pitch_ = u.pitch_rad;
    }
    if (u.fields & TelemetryUpdate::kYaw) {
        att_.push({u.rx_s, u.yaw_rad, pitch_, roll_});
    } else if ((u.fields & TelemetryUpdate::kRollPitch)) {
        const double yaw = att_.count > 0 ? att_.newest(0).a : initial_.yaw_rad;
        att_.push({u.rx_s, yaw, pitch_, roll_});
    }
    if (u.fields & TelemetryUpdate::kUtc) {
        haveUtc_ = true;
        utc_unix_s_ = u.utc_unix_s;
        utcAt_s_ = u.rx_s;
    }
    if (u.fields & TelemetryUpdate::kGain) controls_.gain_V = u.gain_V;
    if (u.fields & TelemetryUpdate::kGate) controls_.gate_s = u.gate_s;
    if (u.fields & TelemetryUpdate::kGateMode)
        controls_.gateMode = static_cast<msg::GateMode>(u.gateMode);
    if (u.fields & TelemetryUpdate::kAgc) controls_.agc = u.agc;
    if (u.fields & TelemetryUpdate::kLamps) {
        controls_.lampMask = (controls_.lampMask & ~u.lampBits) | (u.lampMask & u.lampBits);
    }
    return true;
}

void PlatformTrack::sample(double t_s, PlatformState& out) const noexcept {
    out = controls_;
    out.t_sample_s = t_s;
    out.lat_deg = initial_.lat_deg;
    out.lon_deg = initial_.lon_deg;
    out.alt_m = initial_.alt_m;
    out.yaw_rad = initial_.yaw_rad;
    out.pitch_rad = initial_.pitch_rad;
    out.roll_rad = initial_.roll_rad;
    Sample s{};
    if (at(pos_, t_s, false, &s)) {
        // Extrapolation can carry a position past the ranges apply() accepts (a track toward
        // a pole): the state handed on stays within them.
        out.lat_deg = std::clamp(s.a, -90.0, 90.0);
        out.lon_deg = s.b;
        out.alt_m = std::clamp(s.c, kMinAlt_m, kMaxAlt_m);
    }
    if (at(att_, t_s, true, &s)) {
        out.yaw_rad = s.a;
        out.pitch_rad = s.b;
        out.roll_rad = s.c;
    }
    out.poseFromTelemetry = initial_.poseFromTelemetry || pos_.count > 0 || att_.count > 0;
    out.utc_unix_s = haveUtc_ ? utc_unix_s_ + (t_s - utcAt_s_) : initial_.utc_unix_s + t_s;
    out.stale = lastRx_s_ < 0.0 || t_s - lastRx_s_ > staleAfter_s_;
    out.telemetryRx_s = lastRx_s_;
}

}  // namespace nvs::rt
