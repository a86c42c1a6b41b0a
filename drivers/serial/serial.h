#pragma once
// Serial telemetry (docs/design.md §6): a termios port behind an interface with a fake, and two
// streaming parsers fed byte by byte — NMEA 0183 (GGA, RMC, HDT, checksum) and MAVLink v1/v2
// (ATTITUDE, GLOBAL_POSITION_INT, CRC with CRC_EXTRA). Parsers allocate nothing, never
// throw, count what they reject and resynchronise on the next start character.
// Written by hand: Debian 12 packages neither an NMEA nor a MAVLink C++ library; the MAVLink
// CRC and the two messages' layouts follow the MAVLink common.xml definition.

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace nvs::drivers {

// ---- NMEA 0183 -------------------------------------------------------------------------------

struct NmeaSentence {
    enum class Type { Gga, Rmc, Hdt };
    Type type = Type::Gga;
    bool valid = false;    // GGA quality > 0, RMC status 'A', HDT always
    double lat_deg = 0.0;  // GGA, RMC
    double lon_deg = 0.0;
    double alt_m = 0.0;         // GGA: height above the ellipsoid (MSL altitude + geoid separation)
    double timeOfDay_s = -1.0;  // GGA, RMC: UTC seconds since midnight
    double utc_unix_s = -1.0;   // RMC: date + time
    double heading_deg = 0.0;   // HDT: true heading
};

struct NmeaCounters {
    std::int64_t sentences = 0;  // accepted
    std::int64_t badChecksum = 0;
    std::int64_t malformed = 0;    // missing '*', bad fields, too long
    std::int64_t unsupported = 0;  // valid but not GGA/RMC/HDT
    // Well formed, but a value outside the protocol's range: latitude beyond ±90°, longitude
    // beyond ±180°, minutes ≥ 60, time of day outside 00:00:00–23:59:60, a date that does
    // not exist (31 February), heading outside 0–360°.
    std::int64_t outOfRange = 0;
};

class NmeaParser {
  public:
    // Feeds one byte; true when it completed a valid, supported sentence (in *out).
    bool push(std::uint8_t byte, NmeaSentence* out) noexcept;
    const NmeaCounters& counters() const { return counters_; }
    // Parses one complete sentence "$...*hh" (without CR LF); exposed for tests.
    bool parseSentence(const char* s, std::size_t len, NmeaSentence* out) noexcept;

  private:
    static constexpr std::size_t kMax = 100;  // NMEA allows 82 characters; tolerate some more
    char buf_[kMax + 1] = {};
    std::size_t len_ = 0;
    bool inSentence_ = false;
    NmeaCounters counters_;
};

// Appends "*hh\r\n" to a sentence body starting with '$' (for tests and fakes).
std::string nmeaWithChecksum(const std::string& body);

// ---- MAVLink -----------------------------------------------------------------------------------

struct MavlinkMessage {
    std::uint32_t msgid = 0;
    std::uint8_t sysid = 0, compid = 0, seq = 0;
    std::uint8_t version = 2;
    std::uint8_t len = 0;
    std::uint8_t payload[255] = {};  // zero-extended (MAVLink 2 trims trailing zeros)
};

struct MavlinkAttitude {
    std::uint32_t time_boot_ms = 0;
    float roll_rad = 0, pitch_rad = 0, yaw_rad = 0;
    float rollspeed_rad_s = 0, pitchspeed_rad_s = 0, yawspeed_rad_s = 0;
};

struct MavlinkGlobalPosition {
    std::uint32_t time_boot_ms = 0;
    double lat_deg = 0, lon_deg = 0;
    double alt_m = 0;  // MSL
    double relativeAlt_m = 0;
    double vx_m_s = 0, vy_m_s = 0, vz_m_s = 0;
    double heading_deg = -1;  // −1: unknown (UINT16_MAX)
};

struct MavlinkCounters {
    std::int64_t messages = 0;  // CRC-checked and accepted
    std::int64_t badCrc = 0;
    std::int64_t unknownId = 0;  // no CRC_EXTRA known: cannot be checked, dropped
    std::int64_t signedFrames = 0;
    // CRC-checked ATTITUDE / GLOBAL_POSITION_INT whose values are outside the message's range
    // (non-finite or |angle| > π, |lat| > 90°, |lon| > 180°, heading > 359.99°): dropped.
    std::int64_t outOfRange = 0;
};

inline constexpr std::uint32_t kMavlinkHeartbeat = 0;
inline constexpr std::uint32_t kMavlinkAttitude = 30;
inline constexpr std::uint32_t kMavlinkGlobalPositionInt = 33;

class MavlinkParser {
  public:
    bool push(std::uint8_t byte, MavlinkMessage* out) noexcept;
    const MavlinkCounters& counters() const { return counters_; }

  private:
    enum class St { Idle, Header, Payload };
    St st_ = St::Idle;
    std::uint8_t frame_[280] = {};
    std::size_t have_ = 0, need_ = 0;
    MavlinkCounters counters_;
};

// CRC-16/MCRF4XX (X.25) as MAVLink uses it, and the CRC_EXTRA of a message (0 if unknown,
// then *known = false).
std::uint16_t mavlinkCrc(const std::uint8_t* data, std::size_t n, std::uint16_t crc = 0xFFFF);
std::uint8_t mavlinkCrcExtra(std::uint32_t msgid, bool* known);
bool decodeAttitude(const MavlinkMessage& m, MavlinkAttitude* out) noexcept;
// True unless a known message holds a value outside its range (MavlinkCounters::outOfRange);
// the parser drops such a message.
bool payloadInRange(const MavlinkMessage& m) noexcept;
bool decodeGlobalPosition(const MavlinkMessage& m, MavlinkGlobalPosition* out) noexcept;
// Frames a payload (for tests and fakes): v1 or v2 (v2 trims trailing zero bytes).
std::vector<std::uint8_t> mavlinkFrame(int version, std::uint32_t msgid,
                                       const std::uint8_t* payload, std::size_t len,
                                       std::uint8_t seq = 0, std::uint8_t sysid = 1,
                                       std::uint8_t compid = 1);

// ---- serial port ------------------------------------------------------------------------------

enum class SerialState { Closed, Open, Lost };

struct SerialCounters {
    std::int64_t bytes = 0;
    std::int64_t errors = 0;   // failed reads
    std::int64_t lost = 0;     // times the device disappeared
    std::int64_t hangups = 0;  // of those, hang-ups (POLLHUP or end of file: USB unplug)
    int lastErrno = 0;
};

class SerialPort {
  public:
    virtual ~SerialPort() = default;
    // Opens the device raw (8N1, no flow control) at `baud`. 0 or -errno.
    virtual int open(const std::string& device, int baud) = 0;
    virtual void close() noexcept = 0;
    // Non-blocking: bytes read (0: nothing pending) or -errno (the port is then Lost for a
    // hang-up — POLLHUP, end of file — or EIO/ENXIO/ENODEV/EBADF, to be reopened by the caller).
    virtual long read(std::uint8_t* buf, std::size_t size) noexcept = 0;
    virtual SerialState state() const noexcept = 0;
    virtual const SerialCounters& counters() const noexcept = 0;
};

// termios tty; non-copyable, closes on destruction.
class TermiosSerialPort final : public SerialPort {
  public:
    TermiosSerialPort() = default;
    ~TermiosSerialPort() override { close(); }
    TermiosSerialPort(const TermiosSerialPort&) = delete;
    TermiosSerialPort& operator=(const TermiosSerialPort&) = delete;
    int open(const std::string& device, int baud) override;
    void close() noexcept override;
    long read(std::uint8_t* buf, std::size_t size) noexcept override;
    SerialState state() const noexcept override { return state_; }
    const SerialCounters& counters() const noexcept override { return counters_; }

  private:
    int lost(int err) noexcept;
    int fd_ = -1;
    SerialState state_ = SerialState::Closed;
    SerialCounters counters_;
};

// Baud rate → termios speed constant; 0 when unsupported.
unsigned baudConstant(int baud);

}  // namespace nvs::drivers
