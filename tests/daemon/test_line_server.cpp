// augerd's sockets without augerd (line_server.hpp): the per-cycle budgets, idle timeouts, the
// cap with eviction, the waiting room that answers `stop` at once, bursts of connections, deferred
// answers, clients that never read, and the socket files' modes whatever the umask. Clients are
// plain sockets in this process; serve() is called as the loop would, with an injected clock.
#include <catch2/catch.hpp>

#include <atomic>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <string>
#include <thread>
#include <vector>

#include <poll.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/un.h>
#include <unistd.h>

#include "line_server.hpp"

using namespace augerd;

namespace {

std::string sock_path(const std::string& tag) {
  return "/tmp/augerd-ls-" + std::to_string(getpid()) + "-" + tag + ".sock";
}

int connect_to(const std::string& path) {
  sockaddr_un a{};
  a.sun_family = AF_UNIX;
  std::strncpy(a.sun_path, path.c_str(), sizeof a.sun_path - 1);
  const int fd = socket(AF_UNIX, SOCK_STREAM | SOCK_CLOEXEC, 0);
  if (connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0) {
    close(fd);
    return -1;
  }
  return fd;
}

void send_text(int fd, const std::string& t) {
  std::size_t off = 0;
  while (off < t.size()) {
    const ssize_t n = send(fd, t.data() + off, t.size() - off, MSG_NOSIGNAL);
    if (n <= 0) return;
    off += std::size_t(n);
  }
}

// What the client has received so far (non-blocking); closed set when the server closed it.
std::string received(int fd, bool* closed = nullptr) {
  std::string got;
  char buf[4096];
  for (;;) {
    const ssize_t n = recv(fd, buf, sizeof buf, MSG_DONTWAIT);
    if (n > 0) {
      got.append(buf, std::size_t(n));
      continue;
    }
    // Closed: end of file, or reset (the server closed with lines of ours unread).
    if (closed) *closed = n == 0 || (errno != EAGAIN && errno != EWOULDBLOCK);
    return got;
  }
}

struct Counting {
  int lines = 0;
  LineServer::Handler handler() {
    return [this](const std::string& l) -> std::optional<std::string> {
      ++lines;
      return "ok " + l;
    };
  }
};

}  // namespace

TEST_CASE("each client gets a budget of lines per cycle; a flood delays nobody else", "[daemon][unit]") {
  LineServer s(sock_path("budget"), LineServerOptions{});
  Counting h;
  std::vector<int> flooders;
  for (int k = 0; k < 4; ++k) {
    flooders.push_back(connect_to(s.path()));
    std::string many;
    for (int i = 0; i < 1000; ++i) many += "status all\n";
    send_text(flooders.back(), many);
  }
  s.serve(0.0, h.handler());
  const int first = h.lines;
  CHECK(first == 4 * 8);  // 8 lines per client per cycle, whatever is waiting
  const int lone = connect_to(s.path());
  send_text(lone, "stop\n");
  s.serve(0.01, h.handler());
  CHECK(received(lone) == "ok stop\n");  // answered in its first cycle despite 4000 waiting lines
  CHECK(h.lines == first + 4 * 8 + 1);
  for (int fd : flooders) close(fd);
  close(lone);
}

TEST_CASE("at the cap an idle client gives way; a waiting connection gets stop and status answered at once",
          "[daemon][unit]") {
  LineServerOptions o;
  o.max_clients = 4;
  o.wait_slot_s = 0.5;
  o.priority_allows = [](const std::string& l) { return l == "stop" || l == "status"; };
  LineServer s(sock_path("cap"), o);
  Counting h;
  std::vector<int> idle;
  for (int k = 0; k < 4; ++k) idle.push_back(connect_to(s.path()));
  s.serve(0.0, h.handler());
  REQUIRE(s.clients() == 4);
  // Every slot taken by clients idle for less than evict_idle_s: a line that needs a slot waits
  // up to wait_slot_s, then is told that augerd is busy.
  int c = connect_to(s.path());
  send_text(c, "vel 1 2 3\n");
  s.serve(0.1, h.handler());
  s.serve(0.11, h.handler());
  bool closed = false;
  CHECK(received(c, &closed).empty());
  CHECK(s.waiting() == 1);
  s.serve(0.1 + o.wait_slot_s * 0.9, h.handler());
  CHECK(received(c, &closed).empty());
  s.serve(0.1 + o.wait_slot_s * 1.01, h.handler());
  CHECK(received(c, &closed).find("error: augerd serves 4 clients and all are busy") == 0);
  CHECK(closed);
  close(c);
  c = connect_to(s.path());
  send_text(c, "stop\n");
  s.serve(0.7, h.handler());
  CHECK(received(c, &closed) == "ok stop\n");  // in its first cycle
  CHECK(closed);  // one answer, then closed
  close(c);
  // A second later the idle clients give way to newcomers, whatever they send.
  c = connect_to(s.path());
  send_text(c, "vel 1 2 3\n");
  s.serve(1.5, h.handler());
  CHECK(received(c, &closed) == "ok vel 1 2 3\n");
  CHECK_FALSE(closed);
  CHECK(s.stats().evicted == 1);
  close(c);
  for (int fd : idle) close(fd);
}

TEST_CASE("stop is answered in its first cycle behind busy clients and a queue that reconnects", "[daemon][unit]") {
  // Issue 28 point 3: 32 active clients and connections queued behind them held `stop` off for
  // 30-100 s: it waited in the kernel's listen queue behind every other connection.
  LineServerOptions o;
  o.priority_allows = [](const std::string& l) { return l == "stop" || l == "status"; };
  LineServer s(sock_path("queue"), o);
  Counting h;
  std::vector<int> active, queued;
  for (int k = 0; k < 32; ++k) active.push_back(connect_to(s.path()));
  s.serve(0.0, h.handler());
  REQUIRE(s.clients() == 32);
  double t = 0;
  auto cycle = [&] {
    t += 0.01;
    for (int fd : active) send_text(fd, "status\n"), received(fd);  // never idle
    s.serve(t, h.handler());
  };
  // 400 connections behind them, more than the waiting room holds: half say nothing, half ask
  // for a slot; then stop. They come over several cycles: the kernel's queue holds what one cycle
  // takes, and a blocking connect beyond it would wait for the next cycle (here: forever).
  for (std::size_t k = 0; k < 400; ++k) {
    if (k > 0 && k % (o.accepts_per_cycle / 2) == 0) cycle();
    const int fd = connect_to(s.path());
    REQUIRE(fd >= 0);
    if (k % 2) send_text(fd, "vel 1 2 3\n");
    queued.push_back(fd);
  }
  const int stopper = connect_to(s.path());
  send_text(stopper, "stop\n");
  cycle();
  bool closed = false;
  CHECK(received(stopper, &closed) == "ok stop\n");
  CHECK(s.clients() == 32);
  CHECK(s.waiting() <= o.max_waiting);
  // Reconnecting clients keep the room full; stop still gets through in its cycle.
  for (int round = 0; round < 20; ++round) {
    for (int k = 0; k < 100; ++k) {
      const int fd = connect_to(s.path());
      if (fd >= 0) close(fd);
    }
    const int st = connect_to(s.path());
    send_text(st, "stop\n");
    cycle();
    CHECK(received(st, &closed) == "ok stop\n");
    close(st);
  }
  close(stopper);
  for (int fd : active) close(fd);
  for (int fd : queued) close(fd);
}

TEST_CASE("idle clients are closed, long lines refused, clients that never read never stall a cycle",
          "[daemon][unit]") {
  LineServerOptions o;
  o.idle_timeout_s = 2.0;
  LineServer s(sock_path("idle"), o);
  Counting h;
  const int quiet = connect_to(s.path());
  const int talker = connect_to(s.path());
  s.serve(0.0, h.handler());
  send_text(talker, "status\n");
  s.serve(1.5, h.handler());
  s.serve(2.5, h.handler());
  bool closed = false;
  received(quiet, &closed);
  CHECK(closed);  // idle 2.5 s
  CHECK(received(talker, &closed) == "ok status\n");
  CHECK_FALSE(closed);  // its last line 1 s ago
  CHECK(s.stats().idle_closed == 1);

  const int longline = connect_to(s.path());
  send_text(longline, std::string(5000, 'x'));
  s.serve(2.6, h.handler());
  s.serve(2.61, h.handler());
  CHECK(received(longline, &closed).find("error: line longer than 4096 bytes") == 0);
  CHECK(closed);

  // A client that sends and never reads: answers pile up to pause_out, then its lines wait in
  // the kernel; a cycle stays short however long this goes on.
  const int deaf = connect_to(s.path());
  std::string flood;
  for (int k = 0; k < 2000; ++k) flood += "status all please, with a long answer\n";
  send_text(deaf, flood);  // 76 kB: fits the socket's buffer, never read back
  LineServer::Handler big = [&](const std::string&) -> std::optional<std::string> {
    ++h.lines;
    return std::string(1000, 'a');
  };
  double worst_s = 0;
  const int before = h.lines;
  for (int k = 0; k < 300; ++k) {
    const auto t0 = std::chrono::steady_clock::now();
    s.serve(2.7 + 0.001 * k, big);
    worst_s = std::max(worst_s, std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
  }
  const int handled = h.lines - before;
  WARN("a client that never reads: " << handled << " lines answered in 300 cycles, longest cycle " << worst_s * 1e3
                                     << " ms");
  CHECK(handled < 300 * 8);  // it was held back
  CHECK(worst_s < 0.005);
  s.serve(100.0, big);  // idle since its last handled line
  received(deaf, &closed);
  CHECK(closed);
  close(deaf);
  close(talker);
  close(longline);
}

TEST_CASE("an answer can come later; the client's next lines wait for it", "[daemon][unit]") {
  LineServer s(sock_path("defer"), LineServerOptions{});
  std::uint64_t waiting = 0;
  std::vector<std::string> seen;
  LineServer::Handler h = [&](const std::string& l) -> std::optional<std::string> {
    seen.push_back(l);
    if (l == "follow x") {
      waiting = s.current_client();
      return std::nullopt;
    }
    return "ok " + l;
  };
  const int c = connect_to(s.path());
  send_text(c, "follow x\nstatus\n");
  s.serve(0.0, h);
  s.serve(0.01, h);
  CHECK(seen == std::vector<std::string>{"follow x"});
  CHECK(received(c).empty());
  s.reply(waiting, "ok follow");
  s.serve(0.02, h);
  CHECK(received(c) == "ok follow\nok status\n");
  close(c);
}

TEST_CASE("a burst of connections waits in the backlog and is served, none refused", "[daemon][unit]") {
  LineServer s(sock_path("burst"), LineServerOptions{});
  std::atomic<bool> run{true};
  std::thread loop([&] {
    Counting h;
    double t = 0;
    while (run) {
      s.serve(t, h.handler());
      t += 0.001;
      std::this_thread::sleep_for(std::chrono::microseconds(500));
    }
  });
  std::atomic<int> answered{0}, refused{0};
  std::vector<std::thread> clients;
  for (int k = 0; k < 50; ++k)
    clients.emplace_back([&] {
      for (int i = 0; i < 40; ++i) {
        const int fd = connect_to(s.path());
        if (fd < 0) {
          ++refused;
          continue;
        }
        send_text(fd, "status\n");
        std::string got;
        char buf[64];
        pollfd p{fd, POLLIN, 0};
        while (got.find('\n') == std::string::npos && poll(&p, 1, 2000) > 0) {
          const ssize_t n = recv(fd, buf, sizeof buf, 0);
          if (n <= 0) break;
          got.append(buf, std::size_t(n));
        }
        answered += got == "ok status\n";
        close(fd);
      }
    });
  for (auto& t : clients) t.join();
  run = false;
  loop.join();
  CHECK(refused == 0);
  CHECK(answered == 2000);
}

TEST_CASE("socket files get the configured mode and group, never the umask's", "[daemon][unit]") {
  const mode_t old = umask(0);  // the most permissive umask: the mode must still be 0660
  LineServerOptions o;
  o.gid = long(getegid());
  struct stat st {};
  {
    LineServer s(sock_path("mode"), o);
    REQUIRE(stat(s.path().c_str(), &st) == 0);
    CHECK((st.st_mode & 07777) == 0660);
    CHECK(st.st_gid == getegid());
  }
  o.mode = 0620;
  {
    LineServer s(sock_path("mode2"), o);
    REQUIRE(stat(s.path().c_str(), &st) == 0);
    CHECK((st.st_mode & 07777) == 0620);
  }
  umask(old);
}
