#include "rt/telemetry/sources.h"

#include <fcntl.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <string_view>

#include "drivers/sinks/file_io.h"
#include "rt/clock/clock.h"
#include "sim/core/error.h"
#include "sim/core/input_file.h"
#include "sim/core/units.h"

namespace nvs::rt {

// ---- CanDecoder ------------------------------------------------------------------------------

CanDecoder::CanDecoder(drivers::DbcDatabase db) : db_(std::move(db)) {
    struct Name {
        const char* name;
        Bind what;
    };
    static constexpr Name kNames[] = {
        {"Latitude_deg", Bind::Lat},    {"Longitude_deg", Bind::Lon},     {"Altitude_m", Bind::Alt},
        {"Roll_deg", Bind::Roll},       {"Pitch_deg", Bind::Pitch},       {"Yaw_deg", Bind::Yaw},
        {"UnixTime_s", Bind::UnixTime}, {"SubSecond_s", Bind::SubSecond}, {"Gain_V", Bind::Gain},
        {"Gate_s", Bind::Gate},         {"GateMode", Bind::GateMode},     {"Agc", Bind::Agc},
    };
    for (const drivers::DbcMessage& m : db_.messages()) {
        std::vector<Binding> b;
        for (const drivers::DbcSignal& s : m.signals) {
            Binding bind{&s, Bind::None, 0};
            for (const Name& n : kNames) {
                if (s.name == n.name) bind.what = n.what;
            }
            if (s.name.size() == 5 && s.name.rfind("Lamp", 0) == 0 && s.name[4] >= '0' &&
                s.name[4] <= '9') {
                bind.what = Bind::Lamp;
                bind.lamp = s.name[4] - '0';
            }
            if (bind.what != Bind::None) b.push_back(bind);
        }
        bindings_.push_back(std::move(b));
    }
}

bool CanDecoder::decode(const drivers::CanFrame& frame, double rx_s, TelemetryUpdate* u) noexcept {
    ++counters_.frames;
    const drivers::DbcMessage* m = db_.find(frame.id, frame.extended);
    if (m == nullptr) {
        ++counters_.unknownId;
        return false;
    }
    if (frame.len < m->size) {
        ++counters_.truncated;  // a short frame is rejected whole: no half-updated state
        return false;
    }
    const std::size_t index = static_cast<std::size_t>(m - db_.messages().data());
    // Every bound signal within its DBC [min|max] first: one value outside it rejects the
    // whole frame, so that no half-updated state reaches the track.
    for (const Binding& b : bindings_[index]) {
        double v = 0.0;
        if (drivers::decodeSignal(*b.signal, frame.data, frame.len, &v) &&
            !drivers::inDeclaredRange(*b.signal, v)) {
            ++counters_.outOfRange;
            return false;
        }
    }
    *u = TelemetryUpdate{};
    u->rx_s = rx_s;
    double unixTime = -1.0, subSecond = 0.0;
    for (const Binding& b : bindings_[index]) {
        double v = 0.0;
        if (!drivers::decodeSignal(*b.signal, frame.data, frame.len, &v)) continue;
        switch (b.what) {
            case Bind::Lat:
                u->lat_deg = v;
                u->fields |= TelemetryUpdate::kLatLon;
                break;
            case Bind::Lon:
                u->lon_deg = v;
                break;
            case Bind::Alt:
                u->alt_m = v;
                u->fields |= TelemetryUpdate::kAlt;
                break;
            case Bind::Roll:
                u->roll_rad = v * kRadPerDeg;
                u->fields |= TelemetryUpdate::kRollPitch;
                break;
            case Bind::Pitch:
                u->pitch_rad = v * kRadPerDeg;
                break;
            case Bind::Yaw:
                u->yaw_rad = v * kRadPerDeg;
                u->fields |= TelemetryUpdate::kYaw;
                break;
            case Bind::UnixTime:
                unixTime = v;
                break;
            case Bind::SubSecond:
                subSecond = v;
                break;
            case Bind::Gain:
                u->gain_V = v;
                u->fields |= TelemetryUpdate::kGain;
                break;
            case Bind::Gate:
                u->gate_s = v;
                u->fields |= TelemetryUpdate::kGate;
                break;
            case Bind::GateMode:
                u->gateMode = static_cast<std::int32_t>(std::lround(v));
                u->fields |= TelemetryUpdate::kGateMode;
                break;
            case Bind::Agc:
                u->agc = v != 0.0;
                u->fields |= TelemetryUpdate::kAgc;
                break;
            case Bind::Lamp:
                u->lampBits |= 1u << b.lamp;
                if (v != 0.0) u->lampMask |= 1u << b.lamp;
                u->fields |= TelemetryUpdate::kLamps;
                break;
            case Bind::None:
                break;
        }
    }
    if (unixTime >= 0.0) {
        u->utc_unix_s = unixTime + subSecond;
        u->fields |= TelemetryUpdate::kUtc;
    }
    if (u->fields != 0) ++counters_.decoded;
    return u->fields != 0;
}

namespace {

std::string canCounters(const CanDecodeCounters& c) {
    char buf[256];
    std::snprintf(buf, sizeof buf,
                  "frames %lld, decoded %lld, unknown id %lld, truncated %lld, out of range "
                  "%lld, bad lines %lld",
                  static_cast<long long>(c.frames), static_cast<long long>(c.decoded),
                  static_cast<long long>(c.unknownId), static_cast<long long>(c.truncated),
                  static_cast<long long>(c.outOfRange), static_cast<long long>(c.badLines));
    return buf;
}

}  // namespace

// ---- ReplayInput -----------------------------------------------------------------------------

ReplayInput::ReplayInput(const std::string& logPath, drivers::DbcDatabase db)
    : path_(logPath), decoder_(std::move(db)) {
    // A regular file of at most 512 MiB (sim/core/input_file.h), read whole at setup.
    const std::string text = readInputFile(logPath, kMaxLogFileBytes, "replay log");
    double t0 = 0.0;
    for (std::size_t pos = 0; pos < text.size();) {
        const std::size_t eol = std::min(text.find('\n', pos), text.size());
        const std::string_view line(text.data() + pos, eol - pos);
        pos = eol + 1;
        if (line.empty() || line[0] == '#') continue;
        Entry e{};
        if (!drivers::parseCandumpLine(line, &e.t_s, &e.frame)) {
            ++decoder_.counters().badLines;
            continue;
        }
        if (entries_.empty()) t0 = e.t_s;
        e.t_s -= t0;  // the log's first frame arrives at run time 0
        if (!entries_.empty() && e.t_s < entries_.back().t_s) e.t_s = entries_.back().t_s;
        entries_.push_back(e);
    }
    if (entries_.empty()) throw SetupError("replay log '" + logPath + "': no candump frames");
}

void ReplayInput::poll(double now_s, PlatformTrack& track) noexcept {
    TelemetryUpdate u;
    while (next_ < entries_.size() && entries_[next_].t_s <= now_s) {
        if (decoder_.decode(entries_[next_].frame, entries_[next_].t_s, &u)) track.apply(u);
        ++next_;
    }
}

std::string ReplayInput::status() const {
    return "replay:" + path_ + ": " + std::to_string(next_) + "/" +
           std::to_string(entries_.size()) + " frames played, " + canCounters(decoder_.counters());
}

std::int64_t ReplayInput::badInput() const noexcept {
    const CanDecodeCounters& c = decoder_.counters();
    return c.unknownId + c.truncated + c.outOfRange + c.badLines;
}

// ---- CanInput --------------------------------------------------------------------------------

CanInput::CanInput(std::unique_ptr<drivers::CanBus> bus, std::string iface, bool fd,
                   drivers::DbcDatabase db, const std::string& recordPath, CanLockstep lockstep)
    : bus_(std::move(bus)),
      iface_(std::move(iface)),
      fd_(fd),
      decoder_(std::move(db)),
      lock_(lockstep) {
    if (lock_.enabled) {
        bool timed = false;
        for (const drivers::DbcMessage& m : decoder_.database().messages()) {
            for (const drivers::DbcSignal& sig : m.signals)
                timed = timed || sig.name == "UnixTime_s";
        }
        if (!timed) {
            throw SetupError("can:" + iface_ +
                             " with --clock sim: the DBC has no UnixTime_s signal, so the "
                             "telemetry carries no time of its own to step the frames by");
        }
    }
    const int rc = bus_->open(iface_, fd_, {});
    if (rc != 0) {
        throw SetupError("can:" + iface_ + ": cannot open: " + std::strerror(-rc) +
                         " (is the interface up? ip link set " + iface_ + " up)");
    }
    if (!recordPath.empty()) {
        recordFd_ = ::open(recordPath.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
        if (recordFd_ < 0) {
            throw SetupError("can record file '" + recordPath + "': " + std::strerror(errno));
        }
    }
}

CanInput::~CanInput() {
    if (recordFd_ >= 0) ::close(recordFd_);
}

void CanInput::record(const drivers::CanFrame& f, double rxReal_s) noexcept {
    if (recordFd_ < 0) return;
    char line[256];
    const std::size_t n =
        drivers::formatCandumpLine(rxReal_s, iface_.c_str(), f, line, sizeof line);
    if (n == 0 || drivers::writeAll(recordFd_, line, n) != 0) ++recordErrors_;
}

bool CanInput::stampAndApply(const drivers::CanFrame& f, double now_s,
                             PlatformTrack& track) noexcept {
    TelemetryUpdate u;
    if (!decoder_.decode(f, 0.0, &u)) return true;  // bad input: counted by the decoder
    if ((u.fields & TelemetryUpdate::kUtc) != 0) {
        ++marks_;
        if (!haveEpoch_) {
            haveEpoch_ = true;
            epochUtc_s_ = u.utc_unix_s;
        }
        const double t_s = u.utc_unix_s - epochUtc_s_;
        if (t_s > now_s) {
            // The loop has not reached this mark: it and everything after it wait.
            held_ = true;
            heldUpdate_ = u;
            heldStamp_s_ = t_s;
            return false;
        }
        stamp_s_ = t_s;
    }
    u.rx_s = stamp_s_;
    track.apply(u);
    return true;
}

void CanInput::pollLockstep(double now_s, PlatformTrack& track) noexcept {
    if (held_) {
        if (heldStamp_s_ > now_s) return;
        held_ = false;
        stamp_s_ = heldStamp_s_;
        heldUpdate_.rx_s = stamp_s_;
        track.apply(heldUpdate_);
    }
    const std::int64_t idle_ns = static_cast<std::int64_t>(lock_.idle_s * 1e9);
    std::int64_t lastFrame_ns = monotonicNow_ns();
    drivers::CanFrame f;
    double rxReal_s = 0.0;
    for (;;) {
        if (lock_.stop != nullptr && lock_.stop->load(std::memory_order_relaxed)) return;
        const int rc =
            bus_->state() == drivers::CanBusState::Open ? bus_->read(&f, &rxReal_s) : -ENETDOWN;
        if (rc == 1) {
            lastFrame_ns = monotonicNow_ns();
            record(f, rxReal_s);
            if (!stampAndApply(f, now_s, track)) return;
            continue;
        }
        // Nothing to read (or a failed read, counted by the bus): wait for the bus, in slices
        // so that the stop flag is seen, unless the stream has ended.
        if (ended_) return;
        const std::int64_t now_ns = monotonicNow_ns();
        if (now_ns - lastFrame_ns >= idle_ns) {
            ended_ = true;
            return;
        }
        if (bus_->state() != drivers::CanBusState::Open) {
            const double wall_s = static_cast<double>(now_ns) * 1e-9;
            if (wall_s - lastReopen_s_ >= 1.0) {
                lastReopen_s_ = wall_s;
                bus_->open(iface_, fd_, {});
            }
            WallClock::sleepUntil(now_ns + 50'000'000);
        } else {
            bus_->waitReadable(50);
        }
    }
}

void CanInput::poll(double now_s, PlatformTrack& track) noexcept {
    if (lock_.enabled) {
        pollLockstep(now_s, track);
        return;
    }
    if (bus_->state() != drivers::CanBusState::Open) {
        // The interface went down or away (ENETDOWN, ENODEV): counted once per loss, the last
        // good state held, and the socket reopened with backoff.
        if (busUp_) {
            ++busLosses_;
            busUp_ = false;
            backoff_.lost(now_s);
        }
        if (!backoff_.due(now_s)) return;
        ++reopenAttempts_;
        if (bus_->open(iface_, fd_, {}) != 0) {
            backoff_.failed(now_s);
            return;
        }
        ++reopened_;
        backoff_.succeeded();
        busUp_ = true;
    }
    const double realtimeNow_s = static_cast<double>(realtimeNow_ns()) * 1e-9;
    drivers::CanFrame f;
    double rxReal_s = 0.0;
    TelemetryUpdate u;
    for (int i = 0; i < 256; ++i) {  // bounded: a flooding bus cannot stall the render thread
        const int rc = bus_->read(&f, &rxReal_s);
        if (rc <= 0) break;
        // Kernel receive time (CLOCK_REALTIME) → run clock, by its age now.
        const double rx_s = now_s - (realtimeNow_s - rxReal_s);
        record(f, rxReal_s);
        if (decoder_.decode(f, rx_s, &u)) track.apply(u);
    }
}

std::string CanInput::status() const {
    std::string lock;
    if (lock_.enabled) {
        lock = ", lockstep: time marks " + std::to_string(marks_) +
               (ended_ ? ", stream ended (silent " + std::to_string(lock_.idle_s) + " s)" : "");
    }
    return "can:" + iface_ + ": " + bus_->status() + ", " + canCounters(decoder_.counters()) +
           ", bus lost " + std::to_string(busLosses_) + ", reopen attempts " +
           std::to_string(reopenAttempts_) + ", reopened " + std::to_string(reopened_) +
           (busUp_ ? "" : ", BUS LOST") +
           (recordErrors_ > 0 ? ", record errors " + std::to_string(recordErrors_) : "") + lock;
}

std::int64_t CanInput::badInput() const noexcept {
    const CanDecodeCounters& c = decoder_.counters();
    return c.unknownId + c.truncated + c.outOfRange + bus_->counters().truncated +
           bus_->counters().errors;
}

// ---- SerialInput -----------------------------------------------------------------------------

SerialInput::SerialInput(std::unique_ptr<drivers::SerialPort> port, std::string device, int baud,
                         Proto proto)
    : port_(std::move(port)), device_(std::move(device)), baud_(baud), proto_(proto) {
    const int rc = port_->open(device_, baud_);
    if (rc != 0) throw SetupError("serial:" + device_ + ": cannot open: " + std::strerror(-rc));
}

void SerialInput::poll(double now_s, PlatformTrack& track) noexcept {
    if (!reconnect(now_s)) return;
    std::uint8_t buf[512];
    for (int i = 0; i < 16; ++i) {
        const long n = port_->read(buf, sizeof buf);
        if (n <= 0) break;
        for (long k = 0; k < n; ++k) {
            TelemetryUpdate u;
            u.rx_s = now_s;
            if (proto_ == Proto::Nmea) {
                drivers::NmeaSentence s;
                if (!nmea_.push(buf[k], &s) || !s.valid) continue;
                switch (s.type) {
                    case drivers::NmeaSentence::Type::Gga:
                        u.fields = TelemetryUpdate::kLatLon | TelemetryUpdate::kAlt;
                        u.lat_deg = s.lat_deg;
                        u.lon_deg = s.lon_deg;
                        u.alt_m = s.alt_m;
                        break;
                    case drivers::NmeaSentence::Type::Rmc:
                        u.fields = TelemetryUpdate::kLatLon | TelemetryUpdate::kUtc;
                        u.lat_deg = s.lat_deg;
                        u.lon_deg = s.lon_deg;
                        u.utc_unix_s = s.utc_unix_s;
                        break;
                    case drivers::NmeaSentence::Type::Hdt:
                        u.fields = TelemetryUpdate::kYaw;
                        u.yaw_rad = s.heading_deg * kRadPerDeg;
                        break;
                }
            } else {
                drivers::MavlinkMessage m;
                if (!mavlink_.push(buf[k], &m)) continue;
                drivers::MavlinkAttitude a;
                drivers::MavlinkGlobalPosition g;
                if (drivers::decodeAttitude(m, &a)) {
                    u.fields = TelemetryUpdate::kRollPitch | TelemetryUpdate::kYaw;
                    u.roll_rad = a.roll_rad;
                    u.pitch_rad = a.pitch_rad;
                    u.yaw_rad = a.yaw_rad;
                } else if (drivers::decodeGlobalPosition(m, &g)) {
                    u.fields = TelemetryUpdate::kLatLon | TelemetryUpdate::kAlt;
                    u.lat_deg = g.lat_deg;
                    u.lon_deg = g.lon_deg;
                    u.alt_m = g.alt_m;
                }
            }
            if (u.fields != 0) track.apply(u);
        }
    }
}

bool SerialInput::reconnect(double now_s) noexcept {
    if (port_->state() == drivers::SerialState::Open) return true;
    // The device went away (a hang-up, EIO: a USB adapter unplugged): counted once per loss,
    // the last good state held (the track goes stale), and the port reopened with backoff.
    if (wasOpen_) {
        ++disconnects_;
        wasOpen_ = false;
        backoff_.lost(now_s);
    }
    if (!backoff_.due(now_s)) return false;
    ++reopenAttempts_;
    if (port_->open(device_, baud_) != 0) {
        backoff_.failed(now_s);
        return false;
    }
    ++reopened_;
    backoff_.succeeded();
    wasOpen_ = true;
    return true;
}

std::string SerialInput::status() const {
    const drivers::SerialCounters& c = port_->counters();
    char buf[512];
    if (proto_ == Proto::Nmea) {
        const drivers::NmeaCounters& n = nmea_.counters();
        std::snprintf(
            buf, sizeof buf,
            "serial:%s nmea: bytes %lld, sentences %lld, bad checksum %lld, malformed "
            "%lld, out of range %lld, unsupported %lld, read errors %lld, disconnects %lld, "
            "hang-ups %lld, reopen attempts %lld, reopened %lld%s",
            device_.c_str(), static_cast<long long>(c.bytes), static_cast<long long>(n.sentences),
            static_cast<long long>(n.badChecksum), static_cast<long long>(n.malformed),
            static_cast<long long>(n.outOfRange), static_cast<long long>(n.unsupported),
            static_cast<long long>(c.errors), static_cast<long long>(disconnects_),
            static_cast<long long>(c.hangups), static_cast<long long>(reopenAttempts_),
            static_cast<long long>(reopened_), wasOpen_ ? "" : ", PORT LOST");
    } else {
        const drivers::MavlinkCounters& m = mavlink_.counters();
        std::snprintf(buf, sizeof buf,
                      "serial:%s mavlink: bytes %lld, messages %lld, bad crc %lld, out of range "
                      "%lld, unknown id %lld, read errors %lld, disconnects %lld, hang-ups %lld, "
                      "reopen attempts "
                      "%lld, reopened %lld%s",
                      device_.c_str(), static_cast<long long>(c.bytes),
                      static_cast<long long>(m.messages), static_cast<long long>(m.badCrc),
                      static_cast<long long>(m.outOfRange), static_cast<long long>(m.unknownId),
                      static_cast<long long>(c.errors), static_cast<long long>(disconnects_),
                      static_cast<long long>(c.hangups), static_cast<long long>(reopenAttempts_),
                      static_cast<long long>(reopened_), wasOpen_ ? "" : ", PORT LOST");
    }
    return buf;
}

std::int64_t SerialInput::badInput() const noexcept {
    if (proto_ == Proto::Nmea) {
        return nmea_.counters().badChecksum + nmea_.counters().malformed +
               nmea_.counters().outOfRange + disconnects_;
    }
    return mavlink_.counters().badCrc + mavlink_.counters().outOfRange + disconnects_;
}

// ---- TelemetryPlatform -----------------------------------------------------------------------

TelemetryPlatform::TelemetryPlatform(std::unique_ptr<TelemetryInput> input,
                                     const PlatformState& initial, double staleAfter_s,
                                     double maxExtrapolation_s, bool badInputFatal)
    : input_(std::move(input)),
      track_(initial, staleAfter_s, maxExtrapolation_s),
      badInputFatal_(badInputFatal) {}

void TelemetryPlatform::sample(double t_sample_s, double now_s, PlatformState& out) noexcept {
    input_->poll(now_s, track_);
    track_.sample(t_sample_s, out);
}

std::string TelemetryPlatform::status() const {
    return input_->status() + ", updates " + std::to_string(track_.updates()) + ", rejected " +
           std::to_string(track_.rejected());
}

bool TelemetryPlatform::failed() const noexcept {
    return badInputFatal_ && (input_->badInput() > 0 || track_.rejected() > 0);
}

}  // namespace nvs::rt
