#include <linux/can.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>

#include "drivers/can/can.h"
#include "sim/core/error.h"

namespace nvs::drivers {

std::string CanBus::status() const {
    const CanBusCounters& c = counters();
    const char* st = state() == CanBusState::Open     ? "open"
                     : state() == CanBusState::Failed ? "failed"
                                                      : "closed";
    char buf[256];
    std::snprintf(
        buf, sizeof buf,
        "bus %s, frames %lld, errors %lld, truncated %lld, reopens %lld, dropped %lld%s%s", st,
        static_cast<long long>(c.frames), static_cast<long long>(c.errors),
        static_cast<long long>(c.truncated), static_cast<long long>(c.reopens),
        static_cast<long long>(c.dropped), c.lastErrno != 0 ? ", last error: " : "",
        c.lastErrno != 0 ? std::strerror(c.lastErrno) : "");
    return buf;
}

// ---- SocketCanBus -----------------------------------------------------------------------------

int SocketCanBus::open(const std::string& iface, bool fd, const std::vector<CanFilter>& filters) {
    close();
    if (iface.size() >= IFNAMSIZ) return -ENAMETOOLONG;
    sock_ = ::socket(PF_CAN, SOCK_RAW | SOCK_NONBLOCK | SOCK_CLOEXEC, CAN_RAW);
    if (sock_ < 0) return -errno;
    const auto fail = [this](int err) {
        ::close(sock_);
        sock_ = -1;
        state_ = CanBusState::Failed;
        counters_.lastErrno = err;
        return -err;
    };
    if (fd) {
        const int on = 1;
        if (setsockopt(sock_, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) != 0)
            return fail(errno);
    }
    const int on = 1;
    if (setsockopt(sock_, SOL_SOCKET, SO_TIMESTAMP, &on, sizeof on) != 0) return fail(errno);
    // The kernel's count of frames dropped for a full receive queue, with every frame read.
    if (setsockopt(sock_, SOL_SOCKET, SO_RXQ_OVFL, &on, sizeof on) != 0) return fail(errno);
    if (!filters.empty()) {
        std::vector<can_filter> kf(filters.size());
        for (std::size_t i = 0; i < filters.size(); ++i) {
            kf[i].can_id = filters[i].id;
            kf[i].can_mask = filters[i].mask;
        }
        if (setsockopt(sock_, SOL_CAN_RAW, CAN_RAW_FILTER, kf.data(),
                       static_cast<socklen_t>(kf.size() * sizeof(can_filter))) != 0) {
            return fail(errno);
        }
    }
    ifreq ifr{};
    std::strncpy(ifr.ifr_name, iface.c_str(), IFNAMSIZ - 1);
    if (ioctl(sock_, SIOCGIFINDEX, &ifr) != 0) return fail(errno);
    sockaddr_can addr{};
    addr.can_family = AF_CAN;
    addr.can_ifindex = ifr.ifr_ifindex;
    if (bind(sock_, reinterpret_cast<sockaddr*>(&addr), sizeof addr) != 0) return fail(errno);
    fd_ = fd;
    state_ = CanBusState::Open;
    return 0;
}

void SocketCanBus::close() noexcept {
    if (sock_ >= 0) ::close(sock_);
    sock_ = -1;
    if (state_ == CanBusState::Open) state_ = CanBusState::Closed;
}

int SocketCanBus::read(CanFrame* frame, double* rxRealtime_s) noexcept {
    if (sock_ < 0) return -EBADF;
    canfd_frame kf{};
    iovec iov{&kf, sizeof kf};
    alignas(cmsghdr) char ctrl[CMSG_SPACE(sizeof(timeval)) + CMSG_SPACE(sizeof(std::uint32_t))];
    msghdr msg{};
    msg.msg_iov = &iov;
    msg.msg_iovlen = 1;
    msg.msg_control = ctrl;
    msg.msg_controllen = sizeof ctrl;
    const ssize_t n = recvmsg(sock_, &msg, MSG_DONTWAIT);
    if (n < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR) return 0;
        ++counters_.errors;
        counters_.lastErrno = errno;
        if (errno == ENETDOWN || errno == ENODEV) state_ = CanBusState::Failed;
        return -counters_.lastErrno;
    }
    if (n != static_cast<ssize_t>(CAN_MTU) && n != static_cast<ssize_t>(CANFD_MTU)) {
        ++counters_.truncated;
        return -EBADMSG;
    }
    frame->fd = n == static_cast<ssize_t>(CANFD_MTU);
    frame->extended = (kf.can_id & CAN_EFF_FLAG) != 0;
    frame->rtr = (kf.can_id & CAN_RTR_FLAG) != 0;
    frame->id = kf.can_id & (frame->extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    const std::uint8_t maxLen = frame->fd ? 64 : 8;
    frame->len = kf.len > maxLen ? maxLen : kf.len;
    frame->flags = frame->fd ? kf.flags : 0;
    std::memcpy(frame->data, kf.data, frame->len);
    *rxRealtime_s = 0.0;
    for (cmsghdr* c = CMSG_FIRSTHDR(&msg); c != nullptr; c = CMSG_NXTHDR(&msg, c)) {
        if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_TIMESTAMP) {
            timeval tv{};
            std::memcpy(&tv, CMSG_DATA(c), sizeof tv);
            *rxRealtime_s = static_cast<double>(tv.tv_sec) + static_cast<double>(tv.tv_usec) * 1e-6;
        } else if (c->cmsg_level == SOL_SOCKET && c->cmsg_type == SO_RXQ_OVFL) {
            std::uint32_t drops = 0;
            std::memcpy(&drops, CMSG_DATA(c), sizeof drops);
            counters_.dropped = drops;
        }
    }
    if (*rxRealtime_s == 0.0) {
        timeval tv{};
        gettimeofday(&tv, nullptr);
        *rxRealtime_s = static_cast<double>(tv.tv_sec) + static_cast<double>(tv.tv_usec) * 1e-6;
    }
    ++counters_.frames;
    return 1;
}

int SocketCanBus::waitReadable(int timeout_ms) noexcept {
    if (sock_ < 0) return -EBADF;
    pollfd p{sock_, POLLIN, 0};
    const int n = ::poll(&p, 1, timeout_ms);
    if (n < 0) return errno == EINTR ? 0 : -errno;
    if (n > 0 && (p.revents & (POLLERR | POLLNVAL)) != 0 && (p.revents & POLLIN) == 0) return -EIO;
    return n > 0 ? 1 : 0;
}

int SocketCanBus::write(const CanFrame& frame) noexcept {
    if (sock_ < 0) return -EBADF;
    canfd_frame kf{};
    kf.can_id = frame.id | (frame.extended ? CAN_EFF_FLAG : 0u) | (frame.rtr ? CAN_RTR_FLAG : 0u);
    kf.len = frame.len;
    kf.flags = frame.flags;
    std::memcpy(kf.data, frame.data, frame.len);
    const std::size_t size = frame.fd ? CANFD_MTU : CAN_MTU;
    const ssize_t n = ::write(sock_, &kf, size);
    if (n < 0) {
        ++counters_.errors;
        counters_.lastErrno = errno;
        return -errno;
    }
    return static_cast<std::size_t>(n) == size ? 0 : -EIO;
}

}  // namespace nvs::drivers
