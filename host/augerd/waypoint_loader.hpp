// Reads a `follow` trajectory file off augerd's loop: a file read can block (a FIFO nobody
// writes, a slow disk) or take long (a big file), and the loop must not. One thread per request;
// non-regular files, files over limits::kMaxWaypointFileBytes and more than
// limits::kMaxWaypoints rows are refused; every waypoint is checked against input_limits.hpp.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "auger/trajectory.hpp"

namespace augerd {

class WaypointLoader {
 public:
  struct Result {
    std::vector<auger::Waypoint> waypoints;  // empty on error
    std::string error;                       // "" on success
    bool copied = false;                     // the copy for auger replay was written
  };

  // Starts reading path (relative to augerd's working directory). If copy_path is not empty,
  // the waypoints as read are written there (CSV t_s,x_m,y_m,psi_rad; docs/daemon.md "The log").
  // One request at a time: busy() says whether one is under way.
  void start(const std::string& path, const std::string& copy_path, double now_s);
  bool busy() const { return job_ != nullptr; }
  // The result once the file is read, or after timeout_s an error (before `auger cmd` gives up
  // at 5 s; the reading thread finishes on its own and its result is dropped). Never blocks.
  std::optional<Result> poll(double now_s, double timeout_s = 4.0);

  // The reading itself, synchronous (the thread's body; tests call it directly).
  static Result load(const std::string& path, const std::string& copy_path);

 private:
  struct Job;
  std::shared_ptr<Job> job_;
  double started_s_ = 0;
};

}  // namespace augerd
