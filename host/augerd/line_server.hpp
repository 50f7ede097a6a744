// A non-blocking Unix stream socket serving line protocols to several clients from augerd's
// loop: poll() with a zero timeout, never blocking the 100 Hz cycle.
#pragma once

#include <functional>
#include <string>
#include <vector>

namespace augerd {

class LineServer {
 public:
  // Creates the socket at path (a filesystem path: never a network socket). A stale socket
  // file left by a dead daemon is replaced; a live one (another augerd) is an error.
  // Throws std::runtime_error naming the path.
  explicit LineServer(const std::string& path);
  ~LineServer();
  LineServer(const LineServer&) = delete;
  LineServer& operator=(const LineServer&) = delete;

  // Accepts new clients, reads what they sent, calls handle(line) for each complete line and
  // queues its non-empty answer (a newline is added), writes what the clients can take.
  void serve(const std::function<std::string(const std::string&)>& handle);
  const std::string& path() const { return path_; }
  // Who sent the line being handled (inside handle only): "pid N (comm) uid N" from the
  // socket's peer credentials, for the fault event log's "re-enabled by".
  const std::string& current_peer() const { return current_peer_; }

 private:
  struct Client {
    int fd;
    std::string peer;  // SO_PEERCRED at accept
    std::string in, out;
    bool eof = false;  // the client shut down its side: close once the answers are out
  };
  void drop(std::size_t i);
  static std::string peer_text(int fd);
  std::string path_;
  int fd_ = -1;
  std::vector<Client> clients_;
  std::string current_peer_;
};

}  // namespace augerd
