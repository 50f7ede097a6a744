// One motor module over its serial port, spoken to in the protocol of shared/protocol.h:
// identity, settings (CONFIG / CONFIG_REPORT), and the frame pump. auger-module, `auger step`,
// `auger calib` and augerd (its module bus) use it.
#pragma once

#include "protocol.h"
#include "serial_port.hpp"

#include <deque>
#include <optional>
#include <string>
#include <vector>

namespace auger::io {

class ModuleLink {
public:
    static constexpr unsigned kDefaultBaud = 250000;

    ModuleLink(const std::string& port, unsigned baud = kDefaultBaud);

    // The module's identity. Opening a USB serial port resets an Arduino-style module into
    // its bootloader for about a second, after which the firmware sends IDENTITY by itself;
    // a module that was not reset is asked (REQUEST). Throws after timeout_s.
    proto_identity_t identify(double timeout_s = 4.0);
    // Asks at once (REQUEST 0x82): for a module known to be running.
    proto_identity_t query_identity(double timeout_s = 1.0);
    // The settings in use (REQUEST 0x83 -> CONFIG_REPORT).
    proto_config_t read_config(double timeout_s = 1.0);
    // Writes settings (CONFIG) and returns the module's report of what it stored; throws if
    // the module refused them (motor enabled, invalid values) or did not answer.
    proto_config_t write_config(const proto_config_t& cfg, double timeout_s = 2.0);

    // Blocks up to timeout_s for room in the port's buffer (augerd passes 0: never wait).
    void send_frame(const uint8_t* frame, size_t len, double timeout_s = 1.0);
    // The next frame of `type`, discarding others (telemetry keeps coming), or nothing.
    std::optional<proto_frame_t> wait_frame(uint8_t type, double timeout_s);

    // Non-blocking, for augerd's 100 Hz loop: appends every valid frame the port has now (first
    // those an earlier wait_frame left queued) and returns how many. Throws std::runtime_error
    // naming the port when it fails or hangs up (USB unplugged, pty closed).
    size_t pump(std::vector<proto_frame_t>& out);

    // Frames dropped by the host's parser (CRC, length, type).
    uint16_t dropped() const { return proto_parser_dropped(&parser_); }
    // The host parser's counters (CRC and header errors, bytes skipped), for auger monitor.
    const proto_parser_t& parser_stats() const { return parser_; }
    // Bytes received so far: with no valid frame among them, the line delivers only garbage.
    uint64_t bytes_received() const { return bytes_received_; }
    const std::string& port() const { return port_.path(); }

private:
    void request(uint8_t what);
    SerialPort port_;
    proto_parser_t parser_;
    std::deque<proto_frame_t> frames_;  // decoded, not yet asked for
    uint64_t bytes_received_ = 0;
};

}  // namespace auger::io
