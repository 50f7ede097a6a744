// A connection to one of augerd's line sockets (docs/daemon-protocol.md), shared by `auger cmd`,
// `auger sensor` and the field tools (host/operator): connect, send lines, read answer lines.
#pragma once

#include <string>

namespace auger::io {

constexpr const char* kDefaultCommandsSocket = "/run/augerd/commands.sock";
constexpr const char* kDefaultSensorsSocket = "/run/augerd/sensors.sock";

class AugerdClient {
 public:
  // Connects; throws std::runtime_error naming the path ("is augerd running?").
  explicit AugerdClient(const std::string& path);
  ~AugerdClient();
  AugerdClient(const AugerdClient&) = delete;
  AugerdClient& operator=(const AugerdClient&) = delete;

  bool send_line(const std::string& line);  // adds the newline; false if the socket failed
  // One answer line (without its newline); false on end of file, error or timeout.
  bool read_line(std::string& line, int timeout_ms = 5000);
  // send_line + read_line; throws std::runtime_error if no answer came.
  std::string request(const std::string& line, int timeout_ms = 5000);
  void shutdown_sending();
  int fd() const { return fd_; }
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  int fd_ = -1;
  std::string buf_;
};

}  // namespace auger::io
