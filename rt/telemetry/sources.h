#pragma once
// Telemetry inputs: each takes in what has arrived by run-clock time `now_s` and applies it
// to a PlatformTrack. Bad input (malformed, unknown, short, checksum) is counted; with
// bad_input = "stop" the first one marks the input failed and the run stops.
//
//   CanDecoder      DBC-decoded CAN frames → TelemetryUpdate, by signal name:
//                   Latitude_deg Longitude_deg Altitude_m Roll_deg Pitch_deg Yaw_deg
//                   UnixTime_s SubSecond_s Gain_V Gate_s GateMode Agc Lamp0..Lamp7
//   ReplayInput     a candump log; frame times are shifted so the first is at run time 0
//   CanInput        a CanBus (SocketCAN or fake); optional candump recording; under the sim
//                   clock in lockstep with the telemetry's own time signal (below)
//   SerialInput     a SerialPort with NMEA 0183 or MAVLink framing (drivers/serial)
// A live device that goes away (serial hang-up or EIO, CAN ENETDOWN/ENODEV) is counted once per
// loss, its status says PORT LOST / BUS LOST until it is back, the last good state is held (and
// goes stale), and it is reopened with backoff: 0.1 s, doubling, at most 5 s between tries.
//   TelemetryPlatform  PlatformSource = one input + its PlatformTrack

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "drivers/can/can.h"
#include "drivers/serial/serial.h"
#include "rt/loop/stages.h"
#include "rt/telemetry/track.h"
#include "sim/core/backoff.h"

namespace nvs::rt {

struct CanDecodeCounters {
    std::int64_t frames = 0;
    std::int64_t decoded = 0;
    std::int64_t unknownId = 0;
    std::int64_t truncated = 0;  // shorter than the DBC message
    // A bound signal outside its DBC [min|max], or not finite: the frame is rejected whole.
    std::int64_t outOfRange = 0;
    std::int64_t badLines = 0;  // unreadable candump lines (replay)
};

class CanDecoder {
  public:
    explicit CanDecoder(drivers::DbcDatabase db);
    // True when the frame gave an update.
    bool decode(const drivers::CanFrame& frame, double rx_s, TelemetryUpdate* u) noexcept;
    const CanDecodeCounters& counters() const { return counters_; }
    CanDecodeCounters& counters() { return counters_; }
    const drivers::DbcDatabase& database() const { return db_; }

  private:
    enum class Bind : std::uint8_t {
        None,
        Lat,
        Lon,
        Alt,
        Roll,
        Pitch,
        Yaw,
        UnixTime,
        SubSecond,
        Gain,
        Gate,
        GateMode,
        Agc,
        Lamp
    };
    struct Binding {
        const drivers::DbcSignal* signal;
        Bind what;
        int lamp;
    };
    drivers::DbcDatabase db_;
    std::vector<std::vector<Binding>> bindings_;  // per message, in db order
    CanDecodeCounters counters_;
};

class TelemetryInput {
  public:
    virtual ~TelemetryInput() = default;
    virtual void poll(double now_s, PlatformTrack& track) noexcept = 0;
    virtual std::string status() const = 0;
    // Number of bad-input events so far (for the bad_input = "stop" policy).
    virtual std::int64_t badInput() const noexcept = 0;
};

class ReplayInput final : public TelemetryInput {
  public:
    // Reads the whole log at setup (throws SetupError if unreadable or without a good line).
    ReplayInput(const std::string& logPath, drivers::DbcDatabase db);
    void poll(double now_s, PlatformTrack& track) noexcept override;
    std::string status() const override;
    std::int64_t badInput() const noexcept override;
    std::size_t size() const { return entries_.size(); }

  private:
    struct Entry {
        double t_s;
        drivers::CanFrame frame;
    };
    std::string path_;
    std::vector<Entry> entries_;
    std::size_t next_ = 0;
    CanDecoder decoder_;
};

// Lockstep (the sim clock on a live bus): the loop runs on the telemetry's own time, so arrival
// jitter cannot change a frame. Every decoded message with a time signal (UnixTime_s
// [+ SubSecond_s]) is a time mark; its sample time on the run clock is its UTC minus that of the
// first mark (the first mark is run time 0, as a replayed log's first frame is), and every other
// message takes the sample time of the last mark before it: a sender puts the time mark first,
// then the messages valid at that time. poll(now_s) applies every message with sample time
// ≤ now_s and none later: it reads the bus, waiting when nothing is pending, until a mark later
// than now_s arrives (held back for a later poll), the stop flag is set, or the bus has been
// silent for `idle_s` of wall time, which ends the stream (the loop then runs on with the pose
// held/extrapolated; frames that still arrive are applied, without waiting). A candump log
// written so, played with canplayer, thus gives the same states as `replay:` of the log.
struct CanLockstep {
    bool enabled = false;
    double idle_s = 5.0;                      // wall seconds of silence that end the stream
    const std::atomic<bool>* stop = nullptr;  // set: stop waiting (SIGINT, SIGTERM)
};

class CanInput final : public TelemetryInput {
  public:
    // `recordPath`: when not empty, every received frame is appended as a candump line.
    // Lockstep needs a DBC with a UnixTime_s signal (SetupError otherwise).
    CanInput(std::unique_ptr<drivers::CanBus> bus, std::string iface, bool fd,
             drivers::DbcDatabase db, const std::string& recordPath, CanLockstep lockstep = {});
    ~CanInput() override;
    void poll(double now_s, PlatformTrack& track) noexcept override;
    std::string status() const override;
    std::int64_t badInput() const noexcept override;
    drivers::CanBus& bus() { return *bus_; }

  private:
    void pollLockstep(double now_s, PlatformTrack& track) noexcept;
    void record(const drivers::CanFrame& f, double rxReal_s) noexcept;
    // Lockstep: one frame read → stamped and applied, or held back; false when held back.
    bool stampAndApply(const drivers::CanFrame& f, double now_s, PlatformTrack& track) noexcept;

    std::unique_ptr<drivers::CanBus> bus_;
    std::string iface_;
    bool fd_;
    CanDecoder decoder_;
    int recordFd_ = -1;
    std::int64_t recordErrors_ = 0;
    double lastReopen_s_ = -1e9;
    // Lockstep state.
    CanLockstep lock_;
    bool haveEpoch_ = false;
    double epochUtc_s_ = 0.0;  // the first time mark's UTC [s since the Unix epoch]
    double stamp_s_ = 0.0;     // sample time of the messages since the last mark [run clock]
    bool held_ = false;        // a mark later than the loop's now, not applied yet
    TelemetryUpdate heldUpdate_;
    double heldStamp_s_ = 0.0;
    bool ended_ = false;
    std::int64_t marks_ = 0;
    // Device loss: counted once per loss, reopened with backoff (sim/core/backoff.h).
    Backoff backoff_{kReconnectFirst_s, kReconnectMax_s};
    bool busUp_ = true;
    std::int64_t busLosses_ = 0;
    std::int64_t reopenAttempts_ = 0;
    std::int64_t reopened_ = 0;
};

class SerialInput final : public TelemetryInput {
  public:
    enum class Proto { Nmea, Mavlink };
    SerialInput(std::unique_ptr<drivers::SerialPort> port, std::string device, int baud,
                Proto proto);
    void poll(double now_s, PlatformTrack& track) noexcept override;
    std::string status() const override;
    std::int64_t badInput() const noexcept override;

  private:
    std::unique_ptr<drivers::SerialPort> port_;
    std::string device_;
    int baud_;
    Proto proto_;
    drivers::NmeaParser nmea_;
    drivers::MavlinkParser mavlink_;
    // Device loss (a hang-up, EIO): counted once per loss, reopened with backoff. False while
    // the port is still lost.
    bool reconnect(double now_s) noexcept;
    std::int64_t disconnects_ = 0;
    std::int64_t reopenAttempts_ = 0;
    std::int64_t reopened_ = 0;
    Backoff backoff_{kReconnectFirst_s, kReconnectMax_s};
    bool wasOpen_ = true;
};

class TelemetryPlatform final : public PlatformSource {
  public:
    TelemetryPlatform(std::unique_ptr<TelemetryInput> input, const PlatformState& initial,
                      double staleAfter_s, double maxExtrapolation_s, bool badInputFatal);
    void sample(double t_sample_s, double now_s, PlatformState& out) noexcept override;
    std::string status() const override;
    bool failed() const noexcept override;
    TelemetryInput& input() { return *input_; }

  private:
    std::unique_ptr<TelemetryInput> input_;
    PlatformTrack track_;
    bool badInputFatal_;
};

}  // namespace nvs::rt
