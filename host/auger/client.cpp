// The client of augerd's sockets (docs/daemon-protocol.md):
//   auger cmd [--socket PATH] LINE...     one answer per line, printed; exit 1 on any error
//   auger sensor [--socket PATH] LINE...  only errors come back; exit 1 if any
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <string>
#include <vector>

#include <poll.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include "subcommand.hpp"

namespace {

constexpr const char* kDefaultCommands = "/run/augerd/commands.sock";
constexpr const char* kDefaultSensors = "/run/augerd/sensors.sock";
constexpr int kAnswerTimeout_ms = 5000;  // augerd answers within a loop period or two

int client_usage(std::FILE* f, int code) {
  std::fprintf(f,
               "usage: auger cmd [--socket PATH] LINE...     (default %s)\n"
               "       auger sensor [--socket PATH] LINE...  (default %s)\n"
               "Each LINE is one protocol line, e.g. auger cmd enable 'vel 0.05 0 0' status\n",
               kDefaultCommands, kDefaultSensors);
  return code;
}

bool send_all(int fd, const std::string& s) {
  std::size_t off = 0;
  while (off < s.size()) {
    const ssize_t n = ::send(fd, s.data() + off, s.size() - off, MSG_NOSIGNAL);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) return false;
    off += std::size_t(n);
  }
  return true;
}

// Reads one line (without the newline); false on end of file, error or timeout.
bool read_line(int fd, std::string& buf, std::string& line) {
  for (;;) {
    const auto nl = buf.find('\n');
    if (nl != std::string::npos) {
      line = buf.substr(0, nl);
      buf.erase(0, nl + 1);
      return true;
    }
    pollfd p{fd, POLLIN, 0};
    if (::poll(&p, 1, kAnswerTimeout_ms) <= 0) return false;
    char tmp[1024];
    const ssize_t n = ::recv(fd, tmp, sizeof tmp, 0);
    if (n <= 0) return false;
    buf.append(tmp, std::size_t(n));
  }
}

int run_client(int argc, char** argv) {
  const std::string mode = argv[0];
  std::string path = mode == "cmd" ? kDefaultCommands : kDefaultSensors;
  std::vector<std::string> lines;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") return client_usage(stdout, 0);
    if (a == "--socket" && i + 1 < argc) path = argv[++i];
    else lines.push_back(a);
  }
  if (lines.empty()) return client_usage(stderr, 2);
  sockaddr_un addr{};
  addr.sun_family = AF_UNIX;
  if (path.size() >= sizeof addr.sun_path) {
    std::fprintf(stderr, "auger: socket path too long: %s\n", path.c_str());
    return 2;
  }
  std::memcpy(addr.sun_path, path.c_str(), path.size() + 1);
  const int fd = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (fd < 0 || ::connect(fd, reinterpret_cast<const sockaddr*>(&addr), sizeof addr) != 0) {
    std::fprintf(stderr, "auger: cannot connect to %s: %s (is augerd running?)\n", path.c_str(), std::strerror(errno));
    return 3;
  }
  int status = 0;
  std::string buf, answer;
  if (mode == "cmd") {
    // One line, one answer, in order.
    for (const auto& l : lines) {
      if (!send_all(fd, l + "\n") || !read_line(fd, buf, answer)) {
        std::fprintf(stderr, "auger: no answer from %s to '%s'\n", path.c_str(), l.c_str());
        return 3;
      }
      std::printf("%s\n", answer.c_str());
      if (answer.rfind("error:", 0) == 0) status = 1;
    }
  } else {
    // Valid sensor lines get no answer: send all, shut our side, print what comes back
    // until augerd closes the connection.
    for (const auto& l : lines)
      if (!send_all(fd, l + "\n")) {
        std::fprintf(stderr, "auger: cannot send to %s\n", path.c_str());
        return 3;
      }
    ::shutdown(fd, SHUT_WR);
    while (read_line(fd, buf, answer)) {
      std::printf("%s\n", answer.c_str());
      if (answer.rfind("error:", 0) == 0) status = 1;
    }
  }
  std::fflush(stdout);
  ::close(fd);
  return status;
}

}  // namespace

std::vector<auger::cli::Subcommand> auger::cli::client_subcommands() {
  return {
      {"cmd", "[--socket PATH] LINE...", "send command lines to augerd, print its answers", run_client},
      {"sensor", "[--socket PATH] LINE...", "send sensor lines (pose, imu) to augerd", run_client},
  };
}
