#include "line_server.hpp"

#include <cerrno>
#include <cstring>
#include <fstream>
#include <stdexcept>

#include <fcntl.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

namespace augerd {
namespace {

constexpr std::size_t kMaxLine = 4096;        // longer is not a protocol line: drop the client
constexpr std::size_t kMaxPendingOut = 65536;  // a client that never reads is dropped
constexpr std::size_t kMaxClients = 32;

[[noreturn]] void fail(const std::string& path, const std::string& what) {
  throw std::runtime_error("socket " + path + ": " + what);
}

sockaddr_un address(const std::string& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  if (path.size() >= sizeof a.sun_path) fail(path, "path too long");
  std::memcpy(a.sun_path, path.c_str(), path.size() + 1);
  return a;
}

}  // namespace

LineServer::LineServer(const std::string& path) : path_(path) {
  const sockaddr_un a = address(path);
  struct stat st;
  if (::lstat(path.c_str(), &st) == 0) {
    if (!S_ISSOCK(st.st_mode)) fail(path, "exists and is not a socket");
    // Someone answering means another daemon owns it; refused means a stale file.
    int probe = ::socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
    const bool live = probe >= 0 && ::connect(probe, reinterpret_cast<const sockaddr*>(&a), sizeof a) == 0;
    if (probe >= 0) ::close(probe);
    if (live) fail(path, "in use by another process (is augerd already running?)");
    ::unlink(path.c_str());
  }
  fd_ = ::socket(AF_UNIX, SOCK_STREAM | SOCK_NONBLOCK | SOCK_CLOEXEC, 0);
  if (fd_ < 0) fail(path, std::strerror(errno));
  if (::bind(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a) != 0 || ::listen(fd_, 8) != 0) {
    const int err = errno;
    ::close(fd_);
    fail(path, std::strerror(err));
  }
}

LineServer::~LineServer() {
  for (auto& c : clients_) ::close(c.fd);
  if (fd_ >= 0) {
    ::close(fd_);
    ::unlink(path_.c_str());
  }
}

std::string LineServer::peer_text(int fd) {
  ucred cred{};
  socklen_t len = sizeof cred;
  if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) != 0) return "unknown client";
  std::string comm = "?";
  std::ifstream f("/proc/" + std::to_string(cred.pid) + "/comm");
  if (f) std::getline(f, comm);
  return "pid " + std::to_string(cred.pid) + " (" + comm + ") uid " + std::to_string(cred.uid);
}

void LineServer::drop(std::size_t i) {
  ::close(clients_[i].fd);
  clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(i));
}

void LineServer::serve(const std::function<std::string(const std::string&)>& handle) {
  for (;;) {
    const int c = ::accept4(fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (c < 0) break;  // EAGAIN: nobody waiting (other errors: try again next cycle)
    if (clients_.size() >= kMaxClients) {
      ::close(c);
      continue;
    }
    clients_.push_back(Client{c, peer_text(c), {}, {}, false});
  }
  char buf[2048];
  for (std::size_t i = 0; i < clients_.size();) {
    Client& cl = clients_[i];
    bool gone = false;
    while (!cl.eof) {
      const ssize_t n = ::recv(cl.fd, buf, sizeof buf, 0);
      if (n > 0) {
        cl.in.append(buf, static_cast<std::size_t>(n));
        if (cl.in.size() > kMaxLine && cl.in.find('\n') == std::string::npos) {
          gone = true;
          break;
        }
        continue;
      }
      if (n == 0) cl.eof = true;
      else if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) gone = true;
      break;
    }
    current_peer_ = cl.peer;
    std::size_t nl;
    while (!gone && (nl = cl.in.find('\n')) != std::string::npos) {
      std::string line = cl.in.substr(0, nl);
      cl.in.erase(0, nl + 1);
      std::string answer = handle(line);
      if (!answer.empty()) cl.out += answer + "\n";
    }
    // A last line without its newline still counts when the client has shut down.
    if (!gone && cl.eof && !cl.in.empty()) {
      std::string answer = handle(cl.in);
      cl.in.clear();
      if (!answer.empty()) cl.out += answer + "\n";
    }
    while (!gone && !cl.out.empty()) {
      const ssize_t n = ::send(cl.fd, cl.out.data(), cl.out.size(), MSG_NOSIGNAL);
      if (n > 0) cl.out.erase(0, static_cast<std::size_t>(n));
      else {
        if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) gone = true;
        break;
      }
    }
    if (cl.out.size() > kMaxPendingOut) gone = true;
    if (gone || (cl.eof && cl.out.empty())) drop(i);
    else ++i;
  }
}

}  // namespace augerd
