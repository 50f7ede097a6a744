#include "serial_port.hpp"

#include <cerrno>
#include <cstring>
#include <stdexcept>

#include <fcntl.h>
#include <poll.h>
#include <sys/file.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

namespace auger::io {
namespace {

[[noreturn]] void fail(const std::string& path, const std::string& what)
{
    throw std::runtime_error(path + ": " + what);
}

}  // namespace

double monotonic_s()
{
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return double(ts.tv_sec) + 1e-9 * double(ts.tv_nsec);
}

SerialPort::SerialPort(const std::string& path, unsigned baud) : path_(path)
{
    fd_ = ::open(path.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
    if (fd_ < 0) fail(path, std::string("cannot open: ") + std::strerror(errno));
    // Two programs on one module would interleave frames: refuse, do not wait.
    if (flock(fd_, LOCK_EX | LOCK_NB) != 0) {
        int err = errno;
        ::close(fd_);
        fd_ = -1;
        fail(path, err == EWOULDBLOCK ? "in use by another process (flock)"
                                      : std::string("cannot lock: ") + std::strerror(err));
    }
    termios tio;
    if (tcgetattr(fd_, &tio) != 0) {
        int err = errno;
        ::close(fd_);
        fd_ = -1;
        fail(path, std::string("not a terminal: ") + std::strerror(err));
    }
    cfmakeraw(&tio);
    tio.c_cflag |= CLOCAL | CREAD;
    tio.c_cc[VMIN] = 0;
    tio.c_cc[VTIME] = 0;
    if (tcsetattr(fd_, TCSANOW, &tio) != 0 || !set_any_baud(fd_, baud)) {
        int err = errno;
        ::close(fd_);
        fd_ = -1;
        fail(path, "cannot set raw mode at " + std::to_string(baud) + " baud: " + std::strerror(err));
    }
    tcflush(fd_, TCIOFLUSH);
}

SerialPort::~SerialPort()
{
    if (fd_ >= 0) ::close(fd_);
}

void SerialPort::write_all(const uint8_t* data, size_t len, double timeout_s)
{
    const double end = monotonic_s() + timeout_s;
    while (len > 0) {
        ssize_t n = ::write(fd_, data, len);
        if (n > 0) {
            data += n;
            len -= size_t(n);
            continue;
        }
        if (n < 0 && errno != EAGAIN && errno != EINTR) fail(path_, std::string("write: ") + std::strerror(errno));
        double left = end - monotonic_s();
        if (left <= 0) fail(path_, "write timed out");
        pollfd p{fd_, POLLOUT, 0};
        ::poll(&p, 1, int(left * 1000) + 1);
    }
}

size_t SerialPort::read_some(uint8_t* buf, size_t cap, double timeout_s)
{
    pollfd p{fd_, POLLIN, 0};
    int r = ::poll(&p, 1, timeout_s > 0 ? int(timeout_s * 1000) : 0);
    if (r < 0 && errno != EINTR) fail(path_, std::string("poll: ") + std::strerror(errno));
    if (r <= 0) return 0;
    if (p.revents & (POLLERR | POLLNVAL)) fail(path_, "port error (device gone?)");
    ssize_t n = ::read(fd_, buf, cap);
    // A hung-up line (pty master closed, USB adapter gone) may read as end of file instead
    // of an error; either way the module is gone.
    if (n == 0 && (p.revents & POLLHUP)) fail(path_, "hung up (device gone?)");
    if (n < 0) {
        if (errno == EAGAIN || errno == EINTR) return 0;
        fail(path_, std::string("read: ") + std::strerror(errno));
    }
    return size_t(n);
}

}  // namespace auger::io
