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

LineServer::LineServer(const std::string& path, LineServerOptions options) : path_(path), opt_(std::move(options)) {
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
  // The file is created owner-only (no window with the umask's mode), then given its group and
  // mode: who may connect is the configuration's decision, not the umask's.
  const mode_t old_umask = ::umask(0177);
  const int bound = ::bind(fd_, reinterpret_cast<const sockaddr*>(&a), sizeof a);
  const int bind_err = errno;
  ::umask(old_umask);
  auto give_up = [&](const std::string& what) {
    ::close(fd_);
    fd_ = -1;
    if (bound == 0) ::unlink(path.c_str());
    fail(path, what);
  };
  if (bound != 0) give_up(std::strerror(bind_err));
  if (opt_.gid >= 0 && ::chown(path.c_str(), static_cast<uid_t>(-1), static_cast<gid_t>(opt_.gid)) != 0)
    give_up("cannot give it group " + std::to_string(opt_.gid) + ": " + std::strerror(errno));
  if (::chmod(path.c_str(), static_cast<mode_t>(opt_.mode)) != 0)
    give_up("cannot set its mode: " + std::string(std::strerror(errno)));
  // The kernel's queue holds no more than one serve() takes: whatever is in it is taken in the
  // next cycle, so a `stop` never waits behind thousands of queued connections. Beyond it, a
  // blocking connect waits until the next cycle makes room (woken with every other waiting
  // client, not behind them); a burst is served, none refused.
  if (::listen(fd_, int(opt_.accepts_per_cycle)) != 0) give_up(std::strerror(errno));
}

LineServer::~LineServer() {
  for (auto& c : clients_) ::close(c.fd);
  for (auto& c : waiting_) ::close(c.fd);
  if (fd_ >= 0) {
    ::close(fd_);
    ::unlink(path_.c_str());
  }
}

std::string LineServer::current_peer() const {
  if (!current_) return "unknown client";
  std::string comm = "?";
  std::ifstream f("/proc/" + std::to_string(current_->pid) + "/comm");
  if (f) std::getline(f, comm);
  return "pid " + std::to_string(current_->pid) + " (" + comm + ") uid " + std::to_string(current_->uid);
}

void LineServer::drop(std::size_t i) {
  ::close(clients_[i].fd);
  clients_.erase(clients_.begin() + static_cast<std::ptrdiff_t>(i));
}

bool LineServer::take_slot(double now_s) {
  if (clients_.size() < opt_.max_clients) return true;
  // Full: the client idle the longest gives way, if it has been idle a while.
  std::size_t victim = clients_.size();
  double idle = opt_.evict_idle_s;
  for (std::size_t i = 0; i < clients_.size(); ++i) {
    const Client& c = clients_[i];
    if (!c.deferred && now_s - c.last_line_s >= idle) idle = now_s - c.last_line_s, victim = i;
  }
  if (victim == clients_.size()) return false;
  drop(victim);
  ++stats_.evicted;
  return true;
}

void LineServer::accept_new(double now_s, const Handler& handle) {
  // Everything the kernel holds is taken each cycle: a connection waiting in the kernel's queue
  // could not be looked at, and one queued behind many would wait for all of them.
  for (std::size_t k = 0; k < opt_.accepts_per_cycle; ++k) {
    const int fd = ::accept4(fd_, nullptr, nullptr, SOCK_NONBLOCK | SOCK_CLOEXEC);
    if (fd < 0) return;  // EAGAIN: nobody waiting (EMFILE and the like: the rest next cycle)
    Client c;
    c.fd = fd;
    c.id = next_id_++;
    c.last_line_s = now_s;
    ucred cred{};
    socklen_t len = sizeof cred;
    if (::getsockopt(fd, SOL_SOCKET, SO_PEERCRED, &cred, &len) == 0) c.pid = cred.pid, c.uid = cred.uid;
    ++stats_.accepted;
    if (waiting_.size() >= opt_.max_waiting) {
      // A full room makes way for the newest: the oldest is answered if it asked for `stop`,
      // else told that augerd is busy.
      serve_waiting(waiting_.front(), now_s, handle, true);
      ::close(waiting_.front().fd);
      waiting_.pop_front();
    }
    waiting_.push_back(std::move(c));
  }
}

bool LineServer::serve_waiting(Client& c, double now_s, const Handler& handle, bool force) {
  // Only the first line is looked at, and left in the kernel's buffer unless it is answered
  // here: a priority line is short, so a peek of 256 bytes shows it.
  char buf[256];
  const ssize_t n = ::recv(c.fd, buf, sizeof buf, MSG_PEEK | MSG_DONTWAIT);
  if (n == 0) return true;  // gone before it said anything
  if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) return true;
  const char* nl = n > 0 ? static_cast<const char*>(std::memchr(buf, '\n', std::size_t(n))) : nullptr;
  if (nl && opt_.priority_allows) {
    const std::string line(buf, std::size_t(nl - buf));
    if (opt_.priority_allows(line)) {
      ::recv(c.fd, buf, std::size_t(nl - buf) + 1, MSG_DONTWAIT);
      current_ = &c;
      const std::optional<std::string> a = handle(line);  // a priority line is never deferred
      current_ = nullptr;
      if (a && !a->empty()) c.out = *a + "\n";
      bool gone = false;
      flush(c, gone);  // a short answer into an empty socket buffer: all of it
      ++stats_.priority;
      return true;
    }
  }
  const bool said = n > 0;
  if (force || (said && now_s - c.last_line_s >= opt_.wait_slot_s)) {
    c.out = "error: augerd serves " + std::to_string(opt_.max_clients) +
            " clients and all are busy; try again later (stop and status are answered at once)\n";
    bool gone = false;
    flush(c, gone);
    ++stats_.busy;
    return true;
  }
  if (!said && now_s - c.last_line_s > opt_.idle_timeout_s) {
    ++stats_.idle_closed;
    return true;
  }
  return false;
}

void LineServer::serve_waiting_room(double now_s, const Handler& handle) {
  // Oldest first into the slots that are free (or freed by an idle client).
  while (!waiting_.empty() && take_slot(now_s)) {
    clients_.push_back(std::move(waiting_.front()));
    clients_.back().last_line_s = now_s;
    waiting_.pop_front();
  }
  for (auto it = waiting_.begin(); it != waiting_.end();) {
    if (serve_waiting(*it, now_s, handle, false)) {
      ::close(it->fd);
      it = waiting_.erase(it);
    } else {
      ++it;
    }
  }
}

void LineServer::handle_lines(Client& c, const Handler& handle, std::size_t budget) {
  current_ = &c;
  auto answer = [&](const std::string& line) {
    const std::optional<std::string> a = handle(line);
    if (!a) c.deferred = true;
    else if (!a->empty()) c.out += *a + "\n";
  };
  for (std::size_t n = 0; n < budget && !c.deferred && !c.closing && c.out.size() < opt_.pause_out; ++n) {
    const std::size_t nl = c.in.find('\n');
    if (nl == std::string::npos) {
      // A last line without its newline still counts when the client has shut down.
      if (c.eof && !c.in.empty()) {
        std::string line;
        line.swap(c.in);
        answer(line);
      }
      break;
    }
    std::string line = c.in.substr(0, nl);
    c.in.erase(0, nl + 1);
    answer(line);
  }
  current_ = nullptr;
}

void LineServer::flush(Client& c, bool& gone) {
  while (!c.out.empty()) {
    const ssize_t n = ::send(c.fd, c.out.data(), c.out.size(), MSG_NOSIGNAL | MSG_DONTWAIT);
    if (n > 0) {
      c.out.erase(0, static_cast<std::size_t>(n));
      continue;
    }
    if (n < 0 && errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) gone = true;
    break;
  }
  if (c.out.size() > opt_.max_pending_out) {
    gone = true;  // it does not read its answers
    ++stats_.slow_readers;
  }
}

void LineServer::serve(double now_s, const Handler& handle) {
  accept_new(now_s, handle);
  serve_waiting_room(now_s, handle);
  char buf[4096];
  for (std::size_t i = 0; i < clients_.size();) {
    Client& c = clients_[i];
    bool gone = false;
    // Read within the budget, and only as much as will be handled soon: the rest stays in the
    // kernel's buffer, so a client sending faster than it is served is slowed down, not stored.
    std::size_t got = 0;
    while (!c.eof && !c.closing && got < opt_.bytes_per_cycle && c.in.size() < opt_.bytes_per_cycle) {
      const std::size_t want = std::min(sizeof buf, opt_.bytes_per_cycle - got);
      const ssize_t n = ::recv(c.fd, buf, want, MSG_DONTWAIT);
      if (n > 0) {
        c.in.append(buf, static_cast<std::size_t>(n));
        got += static_cast<std::size_t>(n);
        continue;
      }
      if (n == 0) c.eof = true;
      else if (errno != EAGAIN && errno != EWOULDBLOCK && errno != EINTR) gone = true;
      break;
    }
    const std::size_t nl = c.in.find('\n');
    if (!gone && !c.closing && (nl == std::string::npos ? c.in.size() : nl) > opt_.max_line) {
      c.out += "error: line longer than " + std::to_string(opt_.max_line) + " bytes; closing the connection\n";
      c.in.clear();
      c.closing = true;
      ++stats_.overlong;
    }
    const std::size_t lines_before = c.in.size();
    if (!gone) handle_lines(c, handle, opt_.lines_per_cycle);
    if (c.in.size() != lines_before) c.last_line_s = now_s;
    if (!gone) flush(c, gone);
    const bool finished = (c.eof || c.closing) && c.out.empty() && !c.deferred && (c.closing || c.in.empty());
    const bool idle = !c.deferred && now_s - c.last_line_s > opt_.idle_timeout_s;
    if (idle && !gone && !finished) ++stats_.idle_closed;
    if (gone || finished || idle) drop(i);
    else ++i;
  }
}

void LineServer::reply(std::uint64_t client, const std::string& answer) {
  for (auto& c : clients_) {
    if (c.id != client) continue;
    c.deferred = false;
    if (!answer.empty()) c.out += answer + "\n";
    bool gone = false;
    flush(c, gone);  // a failure shows in the next serve()
    return;
  }
}

}  // namespace augerd
