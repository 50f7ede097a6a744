// A non-blocking Unix stream socket serving a line protocol to several clients from augerd's
// loop. Nothing a client does can block the loop or make a cycle take long: every call is
// non-blocking, each client gets a budget of lines and bytes per cycle (the rest waits in the
// kernel's buffers, which pushes back on the sender), idle clients are closed. Every cycle
// takes new connections out of the kernel's listen queue into a bounded waiting room, so none
// waits behind another there: a waiting connection whose first line is `stop` (or `status`) is
// answered in that cycle without a slot, the others wait for a slot for a bounded time, and a
// full room closes its oldest (docs/daemon.md "Limits and abuse").
#pragma once

#include <sys/types.h>

#include <cstdint>
#include <deque>
#include <functional>
#include <optional>
#include <string>
#include <vector>

namespace augerd {

struct LineServerOptions {
  std::size_t max_clients = 32;        // connections served at once
  std::size_t lines_per_cycle = 8;     // lines handled per client per serve()
  std::size_t bytes_per_cycle = 8192;  // bytes read per client per serve()
  std::size_t max_line = 4096;         // a longer line is not a protocol line: error, then closed
  std::size_t max_pending_out = 65536; // answers a client does not read: closed beyond this
  std::size_t pause_out = 16384;       // no more lines are handled while this much waits to be sent
  // New connections taken out of the kernel's queue per serve(), into the waiting room; also the
  // listen backlog, so whatever the kernel holds is taken in one cycle. As many as the room holds:
  // more would be closed unread in the same cycle, each accept costing the loop a wake-up of
  // every client blocked in connect (512 cost 4-7 ms a cycle against clients reconnecting flat out).
  std::size_t accepts_per_cycle = 256;
  std::size_t max_waiting = 256;       // connections without a slot; beyond: the oldest is closed
  double wait_slot_s = 1.0;            // a line that needs a slot waits this long, then: busy
  double idle_timeout_s = 30;          // no complete line this long: closed
  // At the cap, a new connection takes the slot of the client idle the longest, if that one has
  // sent nothing for this long.
  double evict_idle_s = 1.0;
  // A waiting connection whose first line this allows (augerd: `stop` and `status`) is answered
  // at once, without a slot, and closed after that answer. Null: none.
  std::function<bool(const std::string&)> priority_allows;
  unsigned mode = 0660;  // the socket file's permissions, set explicitly (never from the umask)
  long gid = -1;         // the socket file's group (-1: the process's)
};

class LineServer {
 public:
  // Creates the socket at path (a filesystem path: never a network socket) with the options'
  // mode and group. A stale socket file left by a dead daemon is replaced; a live one (another
  // augerd) or a file that is not a socket is an error. Throws std::runtime_error naming the path.
  LineServer(const std::string& path, LineServerOptions options);
  ~LineServer();
  LineServer(const LineServer&) = delete;
  LineServer& operator=(const LineServer&) = delete;

  // The handler's answer to one line: the text to send (a newline is added; "" sends nothing),
  // or nullopt to answer later with reply(current_client(), ...). The client's further lines
  // wait until then.
  using Handler = std::function<std::optional<std::string>(const std::string& line)>;

  // One cycle at loop time now_s: accepts new clients, reads what they sent within their
  // budgets, calls handle(line) for each complete line, writes what the clients can take,
  // closes idle and finished ones.
  void serve(double now_s, const Handler& handle);
  // A deferred answer; ignored if the client has gone.
  void reply(std::uint64_t client, const std::string& answer);

  const std::string& path() const { return path_; }
  // Inside handle only: the client that sent the line, and who it is ("pid N (comm) uid N" from
  // the socket's peer credentials, for the fault event log).
  std::uint64_t current_client() const { return current_->id; }
  std::string current_peer() const;

  struct Stats {
    std::uint64_t accepted = 0, evicted = 0, priority = 0, busy = 0, idle_closed = 0, overlong = 0, slow_readers = 0;
  };
  const Stats& stats() const { return stats_; }
  std::size_t clients() const { return clients_.size(); }
  std::size_t waiting() const { return waiting_.size(); }

 private:
  struct Client {
    int fd = -1;
    std::uint64_t id = 0;
    pid_t pid = 0;
    uid_t uid = 0;
    std::string in, out;
    bool eof = false;          // the client shut down its side: close once the answers are out
    bool closing = false;      // close once the answers are out (overlong line)
    bool deferred = false;     // waiting for reply()
    double last_line_s = 0;    // loop time of its last complete line (or of the accept)
  };
  void accept_new(double now_s, const Handler& handle);
  bool take_slot(double now_s);
  // A waiting connection: answered if its first line is a priority line; else closed when it
  // has waited too long (or must make room: force). True when it is done with (closed).
  bool serve_waiting(Client& c, double now_s, const Handler& handle, bool force);
  void serve_waiting_room(double now_s, const Handler& handle);
  void handle_lines(Client& c, const Handler& handle, std::size_t budget);
  void flush(Client& c, bool& gone);
  void drop(std::size_t i);
  std::string path_;
  LineServerOptions opt_;
  int fd_ = -1;
  std::uint64_t next_id_ = 1;
  std::vector<Client> clients_;
  std::deque<Client> waiting_;  // accepted, no slot yet; oldest first
  const Client* current_ = nullptr;
  Stats stats_;
};

}  // namespace augerd
