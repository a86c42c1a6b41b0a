#pragma once
// Telemetry inputs: each takes in what has arrived by run-clock time `now_s` and applies it
// to a PlatformTrack. Bad input (malformed, unknown, short, checksum) is counted; with
// bad_input = "stop" the first one marks the input failed and the run stops.
//
//   CanDecoder      DBC-decoded CAN frames → TelemetryUpdate, by signal name:
//                   Latitude_deg Longitude_deg Altitude_m Roll_deg Pitch_deg Yaw_deg
//                   UnixTime_s SubSecond_s Gain_V Gate_s GateMode Agc Lamp0..Lamp7
//   ReplayInput     a candump log; frame times are shifted so the first is at run time 0
//   CanInput        a CanBus (SocketCAN or fake); optional candump recording
//   SerialInput     a SerialPort with NMEA 0183 or MAVLink framing (drivers/serial)
//   TelemetryPlatform  PlatformSource = one input + its PlatformTrack

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "drivers/can/can.h"
#include "drivers/serial/serial.h"
#include "rt/loop/stages.h"
#include "rt/telemetry/track.h"

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

class CanInput final : public TelemetryInput {
  public:
    // `recordPath`: when not empty, every received frame is appended as a candump line.
    CanInput(std::unique_ptr<drivers::CanBus> bus, std::string iface, bool fd,
             drivers::DbcDatabase db, const std::string& recordPath);
    ~CanInput() override;
    void poll(double now_s, PlatformTrack& track) noexcept override;
    std::string status() const override;
    std::int64_t badInput() const noexcept override;
    drivers::CanBus& bus() { return *bus_; }

  private:
    std::unique_ptr<drivers::CanBus> bus_;
    std::string iface_;
    bool fd_;
    CanDecoder decoder_;
    int recordFd_ = -1;
    std::int64_t recordErrors_ = 0;
    double lastReopen_s_ = -1e9;
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
    std::int64_t disconnects_ = 0;
    double lastReopen_s_ = -1e9;
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
