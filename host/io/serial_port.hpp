// A serial port for talking to motor modules: exclusive (flock), raw, any baud rate (Linux
// termios2/BOTHER: 250000 baud is not one of the POSIX rates, and LibSerial 1.0 offers only
// those). Used by auger-module now and by augerd (docs/design.md, "Serial link").
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>

namespace auger::io {

class SerialPort {
public:
    // Opens, locks and configures the port; throws std::runtime_error naming the port and
    // the reason (missing, permission, already locked by another process, baud refused).
    SerialPort(const std::string& path, unsigned baud);
    ~SerialPort();
    SerialPort(const SerialPort&) = delete;
    SerialPort& operator=(const SerialPort&) = delete;

    // Writes all bytes (blocking up to timeout_s); throws on error or timeout.
    void write_all(const uint8_t* data, size_t len, double timeout_s = 1.0);
    // Reads what is available within timeout_s (0: don't wait); returns the byte count.
    size_t read_some(uint8_t* buf, size_t cap, double timeout_s);

    const std::string& path() const { return path_; }
    int fd() const { return fd_; }

private:
    std::string path_;
    int fd_ = -1;
};

// Seconds on CLOCK_MONOTONIC: the clock of every timeout in host/io.
double monotonic_s();

// Sets an arbitrary baud rate on an open tty (termios2, BOTHER). False if the driver refuses.
bool set_any_baud(int fd, unsigned baud);

}  // namespace auger::io
