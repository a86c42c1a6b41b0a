#pragma once
// SocketCAN telemetry input (docs/design.md §6): CAN / CAN FD frames, a small DBC decoder, candump
// log files, and a thin RAII wrapper of the raw socket behind an interface with an in-memory fake.

#include <cstdint>
#include <deque>
#include <string>
#include <string_view>
#include <vector>

namespace nvs::drivers {

struct CanFrame {
    std::uint32_t id = 0;    // 11-bit or 29-bit identifier
    bool extended = false;   // 29-bit identifier
    bool fd = false;         // CAN FD frame
    bool rtr = false;        // remote request (no data)
    std::uint8_t flags = 0;  // CAN FD flags (BRS, ESI)
    std::uint8_t len = 0;    // data bytes, 0..8 (classic) or 0..64 (FD)
    std::uint8_t data[64] = {};
};

// ---- DBC -----------------------------------------------------------------------------------
// A subset of the Vector DBC format: BO_ (messages) and SG_ (signals) lines; everything else
// (VERSION, NS_, BU_, CM_, BA_, VAL_ …) is skipped. Signal byte order @1 is Intel (little-
// endian, start bit = LSB), @0 is Motorola (big-endian, start bit = MSB in the DBC's sawtooth
// numbering); + unsigned, − two's complement signed. physical = raw · factor + offset.
// Written by hand: Debian 12 has no packaged DBC library for C++ (cantools is Python).

struct DbcSignal {
    std::string name;
    int startBit = 0;
    int length = 1;
    bool intel = true;
    bool isSigned = false;
    double factor = 1.0;
    double offset = 0.0;
    double min = 0.0;
    double max = 0.0;
    std::string unit;
};

struct DbcMessage {
    std::uint32_t id = 0;
    bool extended = false;
    std::string name;
    int size = 8;  // bytes
    std::vector<DbcSignal> signals;
};

// Longest DBC line read; a longer one is an error naming its line.
inline constexpr std::size_t kDbcMaxLineBytes = 65536;

class DbcDatabase {
  public:
    // Throws SetupError naming file:line for a malformed BO_/SG_ line, a line longer than
    // kDbcMaxLineBytes, a signal that does not fit its message or whose [min|max] has
    // min > max. load() reads a regular file of at most 16 MiB (sim/core/input_file.h).
    static DbcDatabase parse(std::string_view text, const std::string& fileName);
    static DbcDatabase load(const std::string& path);

    const std::vector<DbcMessage>& messages() const { return messages_; }
    // nullptr if the identifier is not in the database (no allocation).
    const DbcMessage* find(std::uint32_t id, bool extended) const noexcept;
    const DbcMessage* findByName(std::string_view name) const noexcept;

  private:
    std::vector<DbcMessage> messages_;  // sorted by (extended, id)
};

// The raw bits of a signal. False when the frame is too short to hold it.
bool extractRaw(const DbcSignal& sig, const std::uint8_t* data, int len,
                std::uint64_t* raw) noexcept;
// Physical value = (signed or unsigned raw) · factor + offset. False when the frame is short.
bool decodeSignal(const DbcSignal& sig, const std::uint8_t* data, int len, double* value) noexcept;
// True when a decoded value is finite and within the signal's declared [min|max] (with half
// a raw step of slack for rounding); [0|0] declares no range.
bool inDeclaredRange(const DbcSignal& sig, double value) noexcept;
// Inverse of decodeSignal (rounded to the nearest raw step, clamped to the signal's range of
// raw values); for recording, tests and fakes.
void encodeSignal(const DbcSignal& sig, double value, std::uint8_t* data, int len) noexcept;

// ---- candump log files ---------------------------------------------------------------------
// One frame a line, as candump -l writes and canplayer reads:
//   (1436509052.249713) vcan0 044#2A366C2BBA        classic, 3 hex digits: 11-bit id
//   (1436509052.249713) can0 12345678#R             29-bit id (8 hex digits), remote request
//   (1436509052.249713) can0 123##1112233           CAN FD: "##", one hex digit of flags
// The time is "seconds.fraction", at most 11 digits before the point and 1..9 after it.
// Returns false for a malformed line (counted by the caller, never fatal).
inline constexpr double kMaxCandumpTime_s = 1e11;
bool parseCandumpLine(std::string_view line, double* t_s, CanFrame* frame) noexcept;
// Formats a frame as a candump line with '\n'; returns its length, or 0 if buf is too small or
// t_s is outside [0, kMaxCandumpTime_s).
std::size_t formatCandumpLine(double t_s, const char* iface, const CanFrame& frame, char* buf,
                              std::size_t size) noexcept;

// ---- SocketCAN -----------------------------------------------------------------------------

struct CanFilter {
    std::uint32_t id = 0;
    std::uint32_t mask = 0;
};

struct CanBusCounters {
    std::int64_t frames = 0;     // frames received
    std::int64_t errors = 0;     // failed reads (other than "nothing to read")
    std::int64_t truncated = 0;  // reads shorter than a CAN frame
    std::int64_t reopens = 0;
    // Frames the kernel dropped because this socket's receive queue was full (SO_RXQ_OVFL:
    // the kernel's running count, as of the last frame read). Linux: Documentation/networking/
    // can.rst; socket(7).
    std::int64_t dropped = 0;
    int lastErrno = 0;
};

enum class CanBusState { Closed, Open, Failed };

class CanBus {
  public:
    virtual ~CanBus() = default;
    // Opens interface `iface` (raw socket, CAN FD frames when `fd`, kernel receive timestamps,
    // receive filters; none: everything). 0 or -errno.
    virtual int open(const std::string& iface, bool fd, const std::vector<CanFilter>& filters) = 0;
    virtual void close() noexcept = 0;
    // Non-blocking read: 1 and a frame with its receive time [s since the Unix epoch], 0 when
    // nothing is pending, -errno on failure.
    virtual int read(CanFrame* frame, double* rxRealtime_s) noexcept = 0;
    // Waits up to `timeout_ms` for a frame to read: 1 when one is pending, 0 on timeout,
    // -errno on failure. A reader that must wait for the bus (the sim clock's lockstep) calls it
    // instead of spinning on read().
    virtual int waitReadable(int timeout_ms) noexcept = 0;
    virtual int write(const CanFrame& frame) noexcept = 0;
    virtual CanBusState state() const noexcept = 0;
    virtual const CanBusCounters& counters() const noexcept = 0;
    std::string status() const;
};

// The kernel's raw CAN socket (PF_CAN, SOCK_RAW, CAN_RAW), with CAN_RAW_FD_FRAMES,
// SO_TIMESTAMP and CAN_RAW_FILTER. Non-copyable; closes on destruction.
class SocketCanBus final : public CanBus {
  public:
    SocketCanBus() = default;
    ~SocketCanBus() override { close(); }
    SocketCanBus(const SocketCanBus&) = delete;
    SocketCanBus& operator=(const SocketCanBus&) = delete;
    int open(const std::string& iface, bool fd, const std::vector<CanFilter>& filters) override;
    void close() noexcept override;
    int read(CanFrame* frame, double* rxRealtime_s) noexcept override;
    int waitReadable(int timeout_ms) noexcept override;  // poll(2), POLLIN
    int write(const CanFrame& frame) noexcept override;
    CanBusState state() const noexcept override { return state_; }
    const CanBusCounters& counters() const noexcept override { return counters_; }

  private:
    int sock_ = -1;
    bool fd_ = false;
    CanBusState state_ = CanBusState::Closed;
    CanBusCounters counters_;
};

}  // namespace nvs::drivers
