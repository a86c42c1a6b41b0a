#include <fcntl.h>
#include <poll.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "drivers/serial/serial.h"

namespace nvs::drivers {

unsigned baudConstant(int baud) {
    switch (baud) {
        case 4800:
            return B4800;
        case 9600:
            return B9600;
        case 19200:
            return B19200;
        case 38400:
            return B38400;
        case 57600:
            return B57600;
        case 115200:
            return B115200;
        case 230400:
            return B230400;
        case 460800:
            return B460800;
        case 921600:
            return B921600;
        default:
            return 0;
    }
}

int TermiosSerialPort::open(const std::string& device, int baud) {
    close();
    const speed_t speed = baudConstant(baud);
    if (speed == 0) return -EINVAL;
    fd_ = ::open(device.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) {
        counters_.lastErrno = errno;
        return -errno;
    }
    termios tio{};
    if (tcgetattr(fd_, &tio) != 0) {
        const int e = errno;
        ::close(fd_);
        fd_ = -1;
        return -e;
    }
    cfmakeraw(&tio);  // 8 data bits, no parity, no echo, no line editing
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cflag &= ~static_cast<tcflag_t>(CSTOPB | CRTSCTS);
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    cfsetispeed(&tio, speed);
    cfsetospeed(&tio, speed);
    if (tcsetattr(fd_, TCSANOW, &tio) != 0) {
        const int e = errno;
        ::close(fd_);
        fd_ = -1;
        return -e;
    }
    state_ = SerialState::Open;
    return 0;
}

void TermiosSerialPort::close() noexcept {
    if (fd_ >= 0) ::close(fd_);
    fd_ = -1;
    if (state_ == SerialState::Open) state_ = SerialState::Closed;
}

int TermiosSerialPort::lost(int err) noexcept {
    // The device went away (USB adapter unplugged, the other end of a pty closed): close; the
    // owner reopens it with backoff.
    ++counters_.errors;
    ++counters_.lost;
    counters_.lastErrno = err;
    ::close(fd_);
    fd_ = -1;
    state_ = SerialState::Lost;
    return -err;
}

long TermiosSerialPort::read(std::uint8_t* buf, std::size_t size) noexcept {
    if (fd_ < 0) return -EBADF;
    // With VMIN = VTIME = 0 a read returns 0 both when nothing is pending and at end of file,
    // so a hang-up cannot be told from silence by read() alone. poll() can: a hung-up tty (USB
    // serial disconnect, pty master closed: tty_vhangup) polls POLLHUP, and then reads 0 or
    // fails with EIO (drivers/tty/tty_io.c hung_up_tty_poll, n_tty.c n_tty_poll).
    pollfd p{fd_, POLLIN, 0};
    const int pr = ::poll(&p, 1, 0);
    if (pr < 0) return errno == EINTR ? 0 : lost(errno);
    if (pr == 0) return 0;  // nothing pending
    if ((p.revents & POLLNVAL) != 0) return lost(EBADF);
    const bool hangup = (p.revents & (POLLHUP | POLLERR)) != 0;
    const ssize_t n = ::read(fd_, buf, size);
    if (n > 0) {
        counters_.bytes += n;
        return n;  // what arrived before a hang-up is still read
    }
    if (n == 0) {
        // Readable, yet nothing to read: end of file, the line is hung up.
        ++counters_.hangups;
        return lost(EIO);
    }
    const int e = errno;
    if ((e == EAGAIN || e == EINTR) && !hangup) return 0;
    if (e == EIO || e == ENXIO || e == ENODEV || e == EBADF || hangup) {
        if (hangup) ++counters_.hangups;
        return lost(e == EAGAIN || e == EINTR ? EIO : e);
    }
    ++counters_.errors;
    counters_.lastErrno = e;
    return -e;
}

}  // namespace nvs::drivers
