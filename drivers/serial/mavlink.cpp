#include <cmath>
#include <cstring>

#include "drivers/serial/serial.h"
#include "sim/core/units.h"

namespace nvs::drivers {

namespace {

constexpr std::uint8_t kStxV1 = 0xFE;
constexpr std::uint8_t kStxV2 = 0xFD;
constexpr std::size_t kHeaderV1 = 6;   // STX len seq sys comp msgid
constexpr std::size_t kHeaderV2 = 10;  // STX len incompat compat seq sys comp msgid[3]
constexpr std::uint8_t kIncompatSigned = 0x01;
constexpr std::size_t kSignatureLen = 13;

template <typename T>
T readLe(const std::uint8_t* p) {
    T v;
    std::memcpy(&v, p, sizeof v);  // MAVLink is little-endian, as is every target we build for
    return v;
}

}  // namespace

std::uint16_t mavlinkCrc(const std::uint8_t* data, std::size_t n, std::uint16_t crc) {
    // CRC-16/MCRF4XX, MAVLink's crc_accumulate().
    for (std::size_t i = 0; i < n; ++i) {
        std::uint8_t tmp = static_cast<std::uint8_t>(data[i] ^ (crc & 0xff));
        tmp = static_cast<std::uint8_t>(tmp ^ (tmp << 4));
        crc = static_cast<std::uint16_t>((crc >> 8) ^ (tmp << 8) ^ (tmp << 3) ^ (tmp >> 4));
    }
    return crc;
}

std::uint8_t mavlinkCrcExtra(std::uint32_t msgid, bool* known) {
    // From common.xml: CRC_EXTRA is a checksum of each message's definition.
    *known = true;
    switch (msgid) {
        case kMavlinkHeartbeat:
            return 50;
        case kMavlinkAttitude:
            return 39;
        case kMavlinkGlobalPositionInt:
            return 104;
        default:
            *known = false;
            return 0;
    }
}

bool MavlinkParser::push(std::uint8_t byte, MavlinkMessage* out) noexcept {
    switch (st_) {
        case St::Idle:
            if (byte == kStxV1 || byte == kStxV2) {
                frame_[0] = byte;
                have_ = 1;
                need_ = byte == kStxV1 ? kHeaderV1 : kHeaderV2;
                st_ = St::Header;
            }
            return false;
        case St::Header:
            frame_[have_++] = byte;
            if (have_ < need_) return false;
            {
                const bool v2 = frame_[0] == kStxV2;
                std::size_t total = need_ + frame_[1] + 2;
                if (v2 && (frame_[2] & kIncompatSigned)) total += kSignatureLen;
                if (v2 && (frame_[2] & ~kIncompatSigned)) {
                    // Unknown incompatibility flags: the frame cannot be understood.
                    ++counters_.badCrc;
                    st_ = St::Idle;
                    return false;
                }
                need_ = total;
                st_ = St::Payload;
            }
            return false;
        case St::Payload:
            frame_[have_++] = byte;
            if (have_ < need_) return false;
            st_ = St::Idle;
            break;
    }
    const bool v2 = frame_[0] == kStxV2;
    const std::size_t header = v2 ? kHeaderV2 : kHeaderV1;
    const std::uint8_t len = frame_[1];
    const std::uint32_t msgid = v2 ? static_cast<std::uint32_t>(frame_[7]) |
                                         (static_cast<std::uint32_t>(frame_[8]) << 8) |
                                         (static_cast<std::uint32_t>(frame_[9]) << 16)
                                   : frame_[5];
    bool known = false;
    const std::uint8_t extra = mavlinkCrcExtra(msgid, &known);
    if (!known) {
        ++counters_.unknownId;
        return false;
    }
    std::uint16_t crc = mavlinkCrc(frame_ + 1, header - 1 + len);
    crc = mavlinkCrc(&extra, 1, crc);
    const std::uint16_t got =
        static_cast<std::uint16_t>(frame_[header + len] | (frame_[header + len + 1] << 8));
    if (crc != got) {
        ++counters_.badCrc;
        return false;
    }
    if (v2 && (frame_[2] & kIncompatSigned)) ++counters_.signedFrames;
    out->version = v2 ? 2 : 1;
    out->len = len;
    out->msgid = msgid;
    out->seq = v2 ? frame_[4] : frame_[2];
    out->sysid = v2 ? frame_[5] : frame_[3];
    out->compid = v2 ? frame_[6] : frame_[4];
    std::memset(out->payload, 0, sizeof out->payload);
    std::memcpy(out->payload, frame_ + header, len);
    if (!payloadInRange(*out)) {
        ++counters_.outOfRange;  // a valid frame whose values cannot be right: dropped whole
        return false;
    }
    ++counters_.messages;
    return true;
}

bool payloadInRange(const MavlinkMessage& m) noexcept {
    // Ranges from common.xml: ATTITUDE roll, pitch, yaw in −π..+π [rad] (compared in float, as
    // sent: float(π) is the largest float angle allowed); GLOBAL_POSITION_INT lat ±90° and lon
    // ±180° [degE7], hdg 0..35999 [cdeg] or UINT16_MAX (unknown).
    constexpr float kPiF = static_cast<float>(kPi);
    if (m.msgid == kMavlinkAttitude) {
        MavlinkAttitude a;
        decodeAttitude(m, &a);
        for (const float angle : {a.roll_rad, a.pitch_rad, a.yaw_rad}) {
            if (!(std::fabs(angle) <= kPiF)) return false;  // NaN fails too
        }
        for (const float rate : {a.rollspeed_rad_s, a.pitchspeed_rad_s, a.yawspeed_rad_s}) {
            if (!std::isfinite(rate)) return false;
        }
    } else if (m.msgid == kMavlinkGlobalPositionInt) {
        const std::int32_t lat = readLe<std::int32_t>(m.payload + 4);
        const std::int32_t lon = readLe<std::int32_t>(m.payload + 8);
        const std::uint16_t hdg = readLe<std::uint16_t>(m.payload + 26);
        if (lat < -900000000 || lat > 900000000 || lon < -1800000000 || lon > 1800000000 ||
            (hdg > 35999 && hdg != 0xFFFF)) {
            return false;
        }
    }
    return true;
}

bool decodeAttitude(const MavlinkMessage& m, MavlinkAttitude* out) noexcept {
    if (m.msgid != kMavlinkAttitude) return false;
    const std::uint8_t* p = m.payload;  // wire order: time_boot_ms, roll, pitch, yaw, speeds
    out->time_boot_ms = readLe<std::uint32_t>(p);
    out->roll_rad = readLe<float>(p + 4);
    out->pitch_rad = readLe<float>(p + 8);
    out->yaw_rad = readLe<float>(p + 12);
    out->rollspeed_rad_s = readLe<float>(p + 16);
    out->pitchspeed_rad_s = readLe<float>(p + 20);
    out->yawspeed_rad_s = readLe<float>(p + 24);
    return true;
}

bool decodeGlobalPosition(const MavlinkMessage& m, MavlinkGlobalPosition* out) noexcept {
    if (m.msgid != kMavlinkGlobalPositionInt) return false;
    const std::uint8_t* p = m.payload;  // time, lat, lon, alt, relative_alt, vx, vy, vz, hdg
    out->time_boot_ms = readLe<std::uint32_t>(p);
    out->lat_deg = readLe<std::int32_t>(p + 4) * 1e-7;
    out->lon_deg = readLe<std::int32_t>(p + 8) * 1e-7;
    out->alt_m = readLe<std::int32_t>(p + 12) * 1e-3;
    out->relativeAlt_m = readLe<std::int32_t>(p + 16) * 1e-3;
    out->vx_m_s = readLe<std::int16_t>(p + 20) * 1e-2;
    out->vy_m_s = readLe<std::int16_t>(p + 22) * 1e-2;
    out->vz_m_s = readLe<std::int16_t>(p + 24) * 1e-2;
    const std::uint16_t hdg = readLe<std::uint16_t>(p + 26);
    out->heading_deg = hdg == 0xFFFF ? -1.0 : hdg * 1e-2;
    return true;
}

std::vector<std::uint8_t> mavlinkFrame(int version, std::uint32_t msgid,
                                       const std::uint8_t* payload, std::size_t len,
                                       std::uint8_t seq, std::uint8_t sysid, std::uint8_t compid) {
    std::vector<std::uint8_t> f;
    if (version == 2) {
        while (len > 1 && payload[len - 1] == 0)
            --len;  // MAVLink 2 payload truncation (at least one byte stays)
        f = {kStxV2,
             static_cast<std::uint8_t>(len),
             0,
             0,
             seq,
             sysid,
             compid,
             static_cast<std::uint8_t>(msgid & 0xff),
             static_cast<std::uint8_t>((msgid >> 8) & 0xff),
             static_cast<std::uint8_t>((msgid >> 16) & 0xff)};
    } else {
        f = {kStxV1, static_cast<std::uint8_t>(len),  seq, sysid,
             compid, static_cast<std::uint8_t>(msgid)};
    }
    f.insert(f.end(), payload, payload + len);
    bool known = false;
    const std::uint8_t extra = mavlinkCrcExtra(msgid, &known);
    std::uint16_t crc = mavlinkCrc(f.data() + 1, f.size() - 1);
    crc = mavlinkCrc(&extra, 1, crc);
    f.push_back(static_cast<std::uint8_t>(crc & 0xff));
    f.push_back(static_cast<std::uint8_t>(crc >> 8));
    return f;
}

}  // namespace nvs::drivers
